"""Summary table of s8_results.csv (means over robots and seeds; the seed-mean RMS spread)."""
import pandas as pd, numpy as np, os
OUT = os.environ.get('S2R_OUT') or os.path.join(os.path.dirname(os.path.abspath(__file__)), 'out')
def outpath(name): return os.path.join(OUT, name)
r = pd.read_csv(outpath('s8_results.csv'))
order = list(dict.fromkeys(r.config))
real = r[r.config.str.startswith('REAL')].rms.mean()
rows = []
for c in order:
    g = r[r.config == c]
    per_seed = g.groupby('seed').rms.mean()
    rows.append((c, g.rms.mean(), g.rms.median(), per_seed.std() if len(per_seed) > 1 else np.nan, g.rms.mean() / real,
                 100 * g.inside.mean(), g.nees.mean(), np.median(g.nees), 100 * g.fwd.mean(), g['head'].mean(), len(per_seed)))
t = pd.DataFrame(rows, columns=['config', 'rms_mean', 'rms_median', 'sd_over_seeds', 'x_real', 'inside95_%', 'nees_mean', 'nees_median', 'fwd_bias_cm', 'heading_deg', 'seeds'])
print('| ' + ' | '.join(t.columns) + ' |'); print('|' + '---|' * len(t.columns))
for _, row in t.iterrows():
    print('| ' + ' | '.join(str(v) if isinstance(v, str) else ('' if pd.isna(v) else f'{v:.3g}') for v in row) + ' |')
