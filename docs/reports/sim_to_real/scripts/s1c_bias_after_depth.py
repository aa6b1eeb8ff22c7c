"""1c. Persistent per-(robot, landmark) and per-landmark biases after the depth model and time shift."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
DT = {1: -0.0333, 2: -0.0298, 3: -0.0351, 4: -0.0352, 5: -0.0258}
out = []
for n in ROBOTS:
    d = detections(n, dt=DT[n]); d = d[robust_inliers(d.er.values, d.eb.values, d.rt.values)].copy()
    A = np.column_stack([np.ones(len(d)), d.rt * np.cos(d.bt)]); c = np.linalg.lstsq(A, d.r, rcond=None)[0]
    d['res_r'] = d.r - A @ c; d['res_b'] = d.eb - d.eb.mean(); out.append(d)
d = pd.concat(out)
def split_half(df, key, col):
    h = []
    for _, g in df.groupby(key):
        if len(g) < 20: continue
        g = g.sort_values('t'); m = len(g) // 2
        h.append((g[col].values[:m].mean(), g[col].values[m:].mean(), len(g)))
    h = np.array(h); w = h[:, 2] / h[:, 2].sum()
    return np.sum(w * h[:, 0] * h[:, 1]), np.corrcoef(h[:, 0], h[:, 1])[0, 1], len(h)
for col, sc, unit in (('res_r', 100, 'cm'), ('res_b', np.degrees(1), 'deg')):
    tot = d[col].var()
    for key in (['robot', 'subject'], 'subject'):
        cov, r, k = split_half(d, key, col)
        print(f"{col} by {key}: split-half persistent variance {cov/tot:.3f} of {sc*np.sqrt(tot):.2f} {unit} total sd (persistent sd {sc*np.sqrt(max(cov,0)):.2f} {unit}); half-mean corr {r:.2f} over {k} groups")
    print("   per landmark means:", (sc * d.groupby('subject')[col].mean()).round(2).to_dict())
    print("   per robot sd:", (sc * d.groupby('robot')[col].std()).round(2).to_dict())
