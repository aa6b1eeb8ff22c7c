"""6. Misses and false detections vs range, bearing, occlusion by other robots / landmarks, turn rate.
The camera's frames are rebuilt: MRCLAM logs only frames with a detection, at multiples of ~0.235 s."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
from scipy.optimize import minimize
L = landmarks(); LM = L[['x', 'y']].values; LID = L.index.values
ROBOT_R = 0.165; LM_R = 0.05   # robot footprint radius (the world's), landmark tube radius (the world's 5 cm)
trs = {n: Truth(n) for n in ROBOTS}
alld = pd.concat([detections(n, tr=trs[n]) for n in ROBOTS], ignore_index=True)
alld['inl'] = robust_inliers(alld.er.values, alld.eb.values, alld.rt.values)
inl = alld[alld.inl]
FOV2 = np.quantile(np.abs(inl.bt), 0.995); RMIN = inl.rt.min(); RMAX = np.quantile(inl.rt, 0.995)
print(f"visibility: |true bearing| <= {np.degrees(FOV2):.1f} deg (99.5 % of inliers; max {np.degrees(np.abs(inl.bt).max()):.1f}), true range {RMIN:.2f}-{RMAX:.2f} m (99.5 %; max {inl.rt.max():.2f})")

def frames(n):
    m = measurements(n); t = np.unique(m.t.values)
    # merge stamps within 10 ms (one frame split over two stamps)
    keep = np.r_[True, np.diff(t) > 0.01]; ft = t[keep]
    g = np.diff(ft); P = np.median(g[(g > 0.2) & (g < 0.3)])
    out = [ft[0]]; logged = [True]
    for a, gap in zip(ft[:-1], g):
        k = int(round(gap / P))
        if 1 < k <= 40:            # up to ~9 s of empty frames; longer gaps: the camera was off
            for j in range(1, k): out.append(a + j * gap / k); logged.append(False)
        out.append(a + gap); logged.append(True)
    return np.array(out), np.array(logged), P, ft

rows = []
for n in ROBOTS:
    ft, logged, P, lt = frames(n)
    tr = trs[n]
    x, y, th, ok = tr.at(ft)
    _, _, thp, ok1 = tr.at(ft + 0.05); _, _, thm, ok2 = tr.at(ft - 0.05)
    w = (thp - thm) / 0.1; ok &= ok1 & ok2
    others = {k: trs[k].at(ft) for k in ROBOTS if k != n}
    d = inl[inl.robot == n]
    # detections -> frame index (nearest frame within 20 ms)
    fi = np.searchsorted(ft, d.t.values); fi = np.clip(fi, 1, len(ft) - 1)
    fi = np.where(np.abs(ft[fi - 1] - d.t.values) < np.abs(ft[fi] - d.t.values), fi - 1, fi)
    seen = set(zip(fi, d.subject.values))
    for li, (lx, ly) in zip(LID, LM):
        dx, dy = lx - x, ly - y; r = np.hypot(dx, dy); b = wrap(np.arctan2(dy, dx) - th)
        vis = ok & (np.abs(b) <= FOV2) & (r >= RMIN) & (r <= RMAX)
        idx = np.where(vis)[0]
        if len(idx) == 0: continue
        ux, uy = dx[idx] / r[idx], dy[idx] / r[idx]
        occ_r = np.zeros(len(idx), bool); near_r = np.full(len(idx), np.inf)
        for k, (ox, oy, _, ook) in others.items():
            px, py = ox[idx] - x[idx], oy[idx] - y[idx]
            s = px * ux + py * uy; perp = np.abs(-px * uy + py * ux)
            between = (s > 0) & (s < r[idx]) & ook[idx]
            occ_r |= between & (perp < ROBOT_R)
            near_r = np.minimum(near_r, np.where(between, perp, np.inf))
        occ_l = np.zeros(len(idx), bool)
        for lj, (mx, my) in zip(LID, LM):
            if lj == li: continue
            px, py = mx - x[idx], my - y[idx]
            s = px * ux + py * uy; perp = np.abs(-px * uy + py * ux)
            occ_l |= (s > 0) & (s < r[idx] - LM_R) & (perp < 2 * LM_R)
        det = np.array([(i, li) in seen for i in idx])
        rows.append(pd.DataFrame(dict(robot=n, lm=li, t=ft[idx], logged=logged[idx], r=r[idx], b=b[idx], w=w[idx],
                                      occ_r=occ_r, near_r=near_r, occ_l=occ_l, det=det)))
    print(f"robot {n}: camera period {P:.4f} s ({1/P:.2f} Hz); logged frames {len(lt)}, rebuilt frames {len(ft)} ({logged.mean()*100:.0f} % logged)")
V = pd.concat(rows, ignore_index=True)
V.to_pickle(outpath('s6_visible.pkl'))
p_all = 1 - V.det.mean(); p_log = 1 - V[V.logged].det.mean()
print(f"\nmiss probability: all rebuilt frames {p_all:.3f} ({len(V)} landmark-frames); logged frames only (calibrate's way) {p_log:.3f}")
print("per robot (all frames / logged only):", {n: (round(1 - g.det.mean(), 3), round(1 - g[g.logged].det.mean(), 3)) for n, g in V.groupby('robot')})
def tab(col, bins, name, f=lambda s: s):
    c = pd.cut(f(V[col]), bins)
    t = V.groupby(c).det.agg(['size', 'mean']); t['miss'] = 1 - t['mean']
    print(f"\nmiss vs {name}:\n" + t[['size', 'miss']].round(3).T.to_string())
tab('r', [0, 1.5, 2, 2.5, 3, 3.5, 4, 5, 6, 9], 'true range [m]')
tab('b', [0, 5, 10, 15, 20, 25, 30, 35], '|true bearing| [deg]', lambda s: np.degrees(np.abs(s)))
tab('w', [0, 0.05, 0.1, 0.2, 0.3, 0.4, 0.6, 2], '|turn rate| [rad/s]', np.abs)
for col, name in (('occ_r', 'another robot within its radius of the line of sight'), ('occ_l', 'another landmark within 10 cm of the line of sight')):
    t = V.groupby(col).det.agg(['size', 'mean'])
    print(f"\nmiss vs {name}: " + ", ".join(f"{k}: n={int(s)} miss={1-m:.3f}" for k, (s, m) in t.iterrows()))
c = pd.cut(V.near_r, [0, 0.1, 0.165, 0.25, 0.4, 0.7, 1.0, np.inf])
t = V.groupby(c).det.agg(['size', 'mean']); print("miss vs nearest other robot's distance from the line of sight [m]:", {str(k): (int(s), round(1 - m, 3)) for k, (s, m) in t.iterrows()})
# per landmark spread
t = V.groupby('lm').det.mean(); print("\nmiss per landmark:", (1 - t).round(2).to_dict())
# logistic regression: constant vs range, |bearing|, occlusion, turn rate, per-landmark not included
X = np.column_stack([np.ones(len(V)), V.r, V.r ** 2, np.abs(V.b), V.b ** 2, np.abs(V.w), V.occ_r, V.occ_l]).astype(float)
yv = V.det.values.astype(float)
def nll(beta, X):
    z = X @ beta; return np.sum(np.logaddexp(0, z) - yv * z)
def fitlog(X):
    s = minimize(nll, np.zeros(X.shape[1]), args=(X,), method='BFGS'); return s.fun, s.x
l0, b0 = fitlog(X[:, :1]); l1, b1 = fitlog(X)
print(f"\nlogistic model of detection (range, range^2, |b|, b^2, |w|, robot-occluded, landmark-occluded): -logL {l1:.0f} vs constant {l0:.0f}: "
      f"deviance drop {2*(l0-l1):.0f} on {X.shape[1]-1} dof; coefs {np.round(b1, 3)}")
# each term's deviance contribution (drop one)
names = ['r', 'r2', '|b|', 'b2', '|w|', 'occ_r', 'occ_l']
for j, nm in enumerate(names, start=1):
    keep = [i for i in range(X.shape[1]) if i != j]
    lj, _ = fitlog(X[:, keep]); print(f"  without {nm}: deviance +{2*(lj-l1):.0f}")
p = 1 / (1 + np.exp(-X @ b1)); V['p_model'] = p
print("  predicted detection prob 5/50/95 % quantiles:", np.round(np.quantile(p, [0.05, 0.5, 0.95]), 3))

# ---- runs: misses are they independent frame to frame? P(miss | miss in the previous frame)
V = V.sort_values(['robot', 'lm', 't'])
prev = V.groupby(['robot', 'lm']).det.shift(1); gap = V.t - V.groupby(['robot', 'lm']).t.shift(1)
m = gap < 0.3
print(f"\nconsecutive frames of a visible landmark: P(detect) {V.det[m].mean():.3f}; P(detect | detected before) {V.det[m & (prev == True)].mean():.3f}; P(detect | missed before) {V.det[m & (prev == False)].mean():.3f}")

# ---- false detections
print("\n## false detections")
out = alld[~alld.inl]
nf = sum(len(frames(n)[0]) for n in ROBOTS); nl = sum(measurements(n).t.nunique() for n in ROBOTS)
unk = sum((measurements(n).subject == -1).sum() for n in ROBOTS)
print(f"outliers (5 MAD) {len(out)} + unknown barcodes {unk} = {len(out)+unk}: {(len(out)+unk)/nl:.4f} per logged frame, {(len(out)+unk)/nf:.4f} per rebuilt frame; {len(out)/len(alld)*100:.2f} % of landmark detections")
print("outlier fraction vs measured range:", alld.groupby(pd.cut(alld.r, [0, 2, 3, 4, 5, 6, 9])).inl.apply(lambda s: round(1 - s.mean(), 4)).to_dict())
print("outlier fraction vs |measured bearing| [deg]:", alld.groupby(pd.cut(np.degrees(np.abs(alld.b)), [0, 10, 20, 25, 30, 35])).inl.apply(lambda s: round(1 - s.mean(), 4)).to_dict())
print("outliers' range error [m] quantiles:", np.round(np.quantile(out.er, [0.1, 0.25, 0.5, 0.75, 0.9]), 2), " bearing error [deg]:", np.round(np.degrees(np.quantile(out.eb, [0.1, 0.25, 0.5, 0.75, 0.9])), 1))
# is another robot near the measured point of an outlier / of an inlier?
def robot_near(dd):
    res = []
    for n, g in dd.groupby('robot'):
        px = g.x + g.r * np.cos(g.th + g.b); py = g.y + g.r * np.sin(g.th + g.b)
        best = np.full(len(g), np.inf)
        for k in ROBOTS:
            if k == n: continue
            ox, oy, _, ook = trs[k].at(g.t.values)
            dist = np.where(ook, np.hypot(ox - px, oy - py), np.inf); best = np.minimum(best, dist)
        res.append(best)
    return np.concatenate(res)
print(f"another robot within 0.3 m of the measured point: outliers {np.mean(robot_near(out) < 0.3):.3f}, inliers {np.mean(robot_near(inl) < 0.3):.3f}")
# the correct landmark of a wrong id? the nearest landmark to the measured point
def nearest_lm(dd):
    px = dd.x + dd.r * np.cos(dd.th + dd.b); py = dd.y + dd.r * np.sin(dd.th + dd.b)
    dist = np.hypot(px.values[:, None] - LM[:, 0], py.values[:, None] - LM[:, 1])
    return LID[dist.argmin(1)], dist.min(1)
nid, nd = nearest_lm(out)
print(f"outliers whose measured point is within 0.3 m of some landmark: {np.mean(nd < 0.3):.3f}, of which another landmark than the id: {np.mean((nid != out.subject.values)[nd < 0.3]):.3f}")

# ---- robot targets (separately)
print("\n## robots as targets (barcode of another robot): errors against that robot's Vicon point")
rr = []
for n in ROBOTS:
    m = measurements(n); m = m[(m.subject >= 1) & (m.subject <= 5) & (m.subject != n)]
    x, y, th, ok = trs[n].at(m.t.values)
    for k in ROBOTS:
        s = (m.subject == k).values
        if s.sum() == 0: continue
        ox, oy, _, ook = trs[k].at(m.t.values[s])
        dx, dy = ox - x[s], oy - y[s]
        rr.append(pd.DataFrame(dict(robot=n, target=k, er=m.r.values[s] - np.hypot(dx, dy), eb=wrap(m.b.values[s] - (np.arctan2(dy, dx) - th[s])),
                                    rt=np.hypot(dx, dy), ok=ok[s] & ook)))
R = pd.concat(rr); R = R[R.ok]
ri = robust_inliers(R.er.values, R.eb.values, R.rt.values)
print(f"{len(R)} robot detections, {(~ri).sum()} outliers; inliers: range error mean {100*R.er[ri].mean():+.1f} cm sd {100*R.er[ri].std():.1f} cm, bearing error mean {np.degrees(R.eb[ri].mean()):+.2f} sd {np.degrees(R.eb[ri].std()):.2f} deg")
