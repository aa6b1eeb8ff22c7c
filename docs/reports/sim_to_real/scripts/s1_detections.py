"""1. Detection errors against the truth: overall, per (robot, landmark) bias, range/bearing bins."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
pd.set_option('display.width', 200)
d = all_detections()
d['inl'] = robust_inliers(d.er.values, d.eb.values, d.rt.values)
print(f"landmark detections with truth: {len(d)}; outliers (5 MAD): {(~d.inl).sum()} ({(~d.inl).mean()*100:.2f} %)")
di = d[d.inl].copy()
# calibrate's bias line in range
A = np.c_[np.ones(len(di)), di.rt]
cr = np.linalg.lstsq(A, di.er, rcond=None)[0]
print(f"range bias line: {cr[0]:+.4f} m {cr[1]:+.4f} r")
di['er_c'] = di.er - (cr[0] + cr[1] * di.rt)          # range error about calibrate's bias line
di['eb_c'] = di.eb - di.eb.mean()
def stats(g):
    return pd.Series({'n': len(g), 'er_mean_cm': 100*g.er.mean(), 'er_sd_cm': 100*g.er.std(),
                      'eb_mean_deg': np.degrees(g.eb.mean()), 'eb_sd_deg': np.degrees(g.eb.std()),
                      'er_c_sd_cm': 100*g.er_c.std()})
t = di.groupby('robot').apply(stats); t.loc['pooled'] = stats(di)
print("\n## errors per robot (inliers)\n", t.round(3).to_string())
# per-(robot, landmark) persistent bias
print("\n## per-(robot, landmark) means (about calibrate's bias line / mean bearing)")
rows = []
def anova(df, key, col):
    g = df.groupby(key)[col]
    n = g.size(); mu = g.mean(); var_w = g.var(ddof=1)
    keep = n >= 10
    tot = df[col].var(ddof=0)
    between = ((n * (mu - df[col].mean())**2)[keep].sum()) / n[keep].sum()
    r2 = between / tot
    return r2, np.sqrt((mu[keep]**2 * n[keep]).sum() / n[keep].sum()), keep.sum()
for col, unit, sc in (('er_c', 'cm', 100), ('eb_c', 'deg', np.degrees(1))):
    r2, rms, k = anova(di, ['robot', 'subject'], col)
    # split-half: means on 1st and 2nd half of each group's detections in time; their covariance
    # across groups estimates the persistent bias variance free of sampling noise (and of
    # correlations shorter than the half-length)
    h = []
    for key, g in di.groupby(['robot', 'subject']):
        if len(g) < 20: continue
        g = g.sort_values('t'); mid = len(g) // 2
        h.append((g[col].values[:mid].mean(), g[col].values[mid:].mean(), len(g), key))
    h = np.array([(a, b, n) for a, b, n, _ in h])
    w = h[:, 2] / h[:, 2].sum()
    cov = np.sum(w * h[:, 0] * h[:, 1])        # about 0 (the line / mean removed)
    tot = di[col].var()
    print(f"{col}: groups {k}, R^2 of group means {r2:.3f}, rms group mean {sc*rms:.2f} {unit}; "
          f"split-half persistent var = {cov/tot:.3f} of total (persistent sd {sc*np.sqrt(max(cov,0)):.2f} {unit}); "
          f"corr of half-means {np.corrcoef(h[:,0],h[:,1])[0,1]:.2f} over {len(h)} groups")
    # per robot
    for n_ in ROBOTS:
        dr = di[di.robot == n_]
        r2n, rmsn, kn = anova(dr, 'subject', col)
        hh = []
        for key, g in dr.groupby('subject'):
            if len(g) < 20: continue
            g = g.sort_values('t'); mid = len(g) // 2
            hh.append((g[col].values[:mid].mean(), g[col].values[mid:].mean(), len(g)))
        hh = np.array(hh); ww = hh[:, 2] / hh[:, 2].sum()
        covn = np.sum(ww * hh[:, 0] * hh[:, 1])
        print(f"   robot {n_}: R^2 {r2n:.3f}, rms mean {sc*rmsn:.2f} {unit}, split-half persistent {covn/dr[col].var():.3f}")
# landmark-only (common to robots: surveyed position / barcode) vs robot-specific
print("\n## landmark means pooled over robots (a survey error would be common to all robots)")
for col, unit, sc in (('er_c', 'cm', 100), ('eb_c', 'deg', np.degrees(1))):
    g = di.groupby('subject')[col].agg(['mean', 'size'])
    print(col, (sc * g['mean']).round(2).to_dict())
    r2, rms, k = anova(di, 'subject', col)
    print(f"  R^2 landmark only {r2:.3f}, rms {sc*rms:.2f} {unit}")
# binned dependence on true range and bearing
print("\n## by true range (inliers)")
di['rbin'] = pd.cut(di.rt, [0, 1.5, 2, 2.5, 3, 3.5, 4, 5, 6, 9])
print(di.groupby('rbin').apply(stats).round(3).to_string())
print("\n## by true bearing [deg] (inliers)")
di['bbin'] = pd.cut(np.degrees(di.bt), [-40, -25, -15, -5, 5, 15, 25, 40])
print(di.groupby('bbin').apply(stats).round(3).to_string())
# bearing error vs bearing: a linear (scale) term?
A = np.c_[np.ones(len(di)), di.bt]
cb = np.linalg.lstsq(A, di.eb, rcond=None)[0]
res = di.eb - A @ cb
print(f"bearing error = {np.degrees(cb[0]):+.3f} deg {cb[1]:+.4f} * bearing; sd {np.degrees(di.eb.std()):.3f} -> {np.degrees(res.std()):.3f} deg")
for n_ in ROBOTS:
    dr = di[di.robot == n_]; A = np.c_[np.ones(len(dr)), dr.bt]
    c = np.linalg.lstsq(A, dr.eb, rcond=None)[0]
    print(f"  robot {n_}: {np.degrees(c[0]):+.3f} deg {c[1]:+.4f} * bearing")
di.to_pickle(outpath('det_inliers.pkl')); d.to_pickle(outpath('det_all.pkl'))
