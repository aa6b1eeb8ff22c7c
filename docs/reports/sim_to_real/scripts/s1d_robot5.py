"""1d. Robot 5's larger depth-model residual: does it drift with time?"""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
for n in ROBOTS:
    d = detections(n, dt=-0.03); d = d[robust_inliers(d.er.values, d.eb.values, d.rt.values)].copy()
    A = np.column_stack([np.ones(len(d)), d.rt * np.cos(d.bt)]); c = np.linalg.lstsq(A, d.r, rcond=None)[0]
    d['res'] = d.r - A @ c; d['rel'] = d.res / d.rt
    w = ((d.t - d.t.min()) // 90).astype(int)
    g = d.groupby(w).rel.mean() * 100
    # per-window scale refit: k in r = a + k r cos b
    ks = []
    for _, gg in d.groupby(w):
        if len(gg) < 30: ks.append(np.nan); continue
        A2 = np.column_stack([np.ones(len(gg)), gg.rt * np.cos(gg.bt)]); ks.append(np.linalg.lstsq(A2, gg.r, rcond=None)[0][1])
    print(f"robot {n}: mean relative residual per 90 s window [%]: {g.round(1).tolist()}; scale k per window {np.round(ks, 3).tolist()}")
