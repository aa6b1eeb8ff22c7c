"""7. Filter optimism from detections: variance of the mean of N consecutive detections of a landmark
(same robot) against the independent-noise prediction var/N; what each correction removes."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
DT = {1: -0.0333, 2: -0.0298, 3: -0.0351, 4: -0.0352, 5: -0.0258}            # s4 (b)
OFF = {1: (-0.0286, 0.0107), 2: (0.0004, -0.0057), 3: (-0.0191, -0.0026), 4: (0.0847, 0.0213), 5: (-0.0060, 0.0010)}
NS = [1, 2, 5, 10, 20, 50]

def base(dt=False, off=False):
    out = []
    for n in ROBOTS:
        tr = Truth(n)
        d = detections(n, dt=DT[n] if dt else 0.0, offset=OFF[n] if off else (0, 0), tr=tr)
        out.append(d)
    return pd.concat(out, ignore_index=True)

ref = base()
ref_inl = robust_inliers(ref.er.values, ref.eb.values, ref.rt.values)
KEYS = set(zip(ref.robot[ref_inl], ref.t[ref_inl], ref.subject[ref_inl]))   # one inlier set for all stages

def stage(dt=False, off=False, depth=False, robot_bias=False, lm_bias=False):
    d = base(dt, off)
    d = d[[k in KEYS for k in zip(d.robot, d.t, d.subject)]].copy()
    er = np.empty(len(d)); eb = np.empty(len(d))
    groups = [d.robot.values == n for n in ROBOTS] if (depth or robot_bias) else [np.ones(len(d), bool)]
    for m in groups:
        g = d[m]
        if depth: A = np.column_stack([np.ones(m.sum()), g.rt * np.cos(g.bt)]); y = g.r.values
        else: A = np.column_stack([np.ones(m.sum()), g.rt]); y = g.er.values
        c = np.linalg.lstsq(A, y, rcond=None)[0]; er[m] = y - A @ c
        eb[m] = g.eb.values - g.eb.values.mean()
    d['er2'] = er; d['eb2'] = eb
    if lm_bias:   # cross-fitted per-(robot, landmark) means: each half corrected by the other half's mean
        d = d.sort_values('t')
        for col in ('er2', 'eb2'):
            new = d[col].copy()
            for _, g in d.groupby(['robot', 'subject']):
                if len(g) < 4: continue
                h = len(g) // 2; a, b = g.index[:h], g.index[h:]
                new[a] = g[col][a] - g[col][b].mean(); new[b] = g[col][b] - g[col][a].mean()
            d[col] = new
    # standardise by the spread line (range) / sd (bearing), per robot if the stage is per robot
    zr = np.empty(len(d)); zb = np.empty(len(d))
    groups = [d.robot.values == n for n in ROBOTS] if (depth or robot_bias) else [np.ones(len(d), bool)]
    for m in groups:
        g = d[m]; B = np.column_stack([np.ones(m.sum()), g.rt])
        s = np.linalg.lstsq(B, np.abs(g.er2.values) * np.sqrt(np.pi / 2), rcond=None)[0]
        zr[m] = g.er2.values / np.maximum(B @ s, 0.005); zb[m] = g.eb2.values / g.eb2.std()
    d['zr'] = zr; d['zb'] = zb
    return d

def mean_var(d, col, N):
    """var of the mean of N consecutive errors (non-overlapping runs) of a (robot, landmark), raw units."""
    means = []
    for _, g in d.sort_values('t').groupby(['robot', 'subject']):
        z = g[col].values; k = len(z) // N
        if k: means.append(z[:k * N].reshape(k, N).mean(1))
    return np.mean(np.concatenate(means) ** 2)

def ratio(d, col, N):
    """N var(mean of N consecutive) / var(single), over non-overlapping runs of N of each (robot, landmark)."""
    means = []; allz = []
    for _, g in d.sort_values('t').groupby(['robot', 'subject']):
        z = g[col].values; k = len(z) // N
        if k == 0: continue
        means.append(z[:k * N].reshape(k, N).mean(1)); allz.append(z[:k * N])
    means = np.concatenate(means); allz = np.concatenate(allz)
    return N * np.mean(means ** 2) / np.mean(allz ** 2)

def twin_ratio(d, N, tau):
    """What a first-order process with time constant tau at the same time stamps gives."""
    num = 0; cnt = 0
    for _, g in d.sort_values('t').groupby(['robot', 'subject']):
        t = g.t.values; k = len(t) // N
        for j in range(k):
            tt = t[j * N:(j + 1) * N]
            num += np.exp(-np.abs(tt[:, None] - tt[None, :]) / tau).sum() / N; cnt += 1
    return num / cnt if tau > 0 else 1.0

STAGES = [
    ('calibrate (bias line, sd line)', {}),
    ('+ per-(robot,landmark) bias (cross-fitted)', dict(lm_bias=True)),
    ('+ time shift only', dict(dt=True)),
    ('+ camera offset only', dict(off=True)),
    ('+ depth model r cos(b), per robot', dict(depth=True)),
    ('depth + time shift + offset (per robot)', dict(depth=True, dt=True, off=True)),
    ('all: depth + dt + offset + (robot,landmark) bias', dict(depth=True, dt=True, off=True, lm_bias=True)),
]
print("rows: stage; single-detection sd (range cm, bearing deg); then N var(mean of N)/var for N in", NS, "(range | bearing)")
out = {}
for name, kw in STAGES:
    d = stage(**kw)
    rr = [ratio(d, 'zr', N) for N in NS]; rb = [ratio(d, 'zb', N) for N in NS]
    out[name] = (rr, rb, 100 * d.er2.std(), np.degrees(d.eb2.std()))
    if name.startswith('calibrate'): CAL = (np.mean(d.er2 ** 2), np.mean(d.eb2 ** 2))
    fr = [mean_var(d, 'er2', N) / (CAL[0] / N) for N in NS]; fb = [mean_var(d, 'eb2', N) / (CAL[1] / N) for N in NS]
    out[name + ' fixed'] = (fr, fb)
    print(f"{'':52s} against calibrate's sd (var(mean of N) / (sigma_cal^2/N)): range " + " ".join(f"{x:5.2f}" for x in fr) + " | bearing " + " ".join(f"{x:5.2f}" for x in fb))
    if name.startswith('calibrate') or name.startswith('all'):
        for n in ROBOTS:
            dn = d[d.robot == n]
            print(f"{'':8s}robot {n}: R(10) range {ratio(dn, 'zr', 10):.2f} bearing {ratio(dn, 'zb', 10):.2f}; R(50) range {ratio(dn, 'zr', 50):.2f} bearing {ratio(dn, 'zb', 50):.2f}")
    print(f"{name:52s} sd {100*d.er2.std():5.2f} cm {np.degrees(d.eb2.std()):.3f} deg | range " + " ".join(f"{x:5.2f}" for x in rr) + " | bearing " + " ".join(f"{x:5.2f}" for x in rb))
d0 = stage()
print("\nthe twin's first-order noise at the same time stamps (tau = calibrate's 1.4 s) gives: " + " ".join(f"N={N}: {twin_ratio(d0, N, 1.4):.2f}" for N in NS))
print("with tau = 3.4 s: " + " ".join(f"N={N}: {twin_ratio(d0, N, 3.4):.2f}" for N in NS))
# time windows: all detections of one landmark by one robot within a window of W seconds
print("\nper window of W seconds (a landmark seen by one robot): mean over window vs var/n_window, calibrate's errors and all corrections")
for name, kw in (STAGES[0], STAGES[-1]):
    d = stage(**kw)
    for W in (1, 2, 5, 10, 30):
        res = {}
        for col in ('zr', 'zb'):
            num = 0; den = 0
            for _, g in d.groupby(['robot', 'subject']):
                w = ((g.t - g.t.min()) // W).astype(int)
                s = g.groupby(w)[col].agg(['sum', 'size'])
                s = s[s['size'] >= 2]
                num += (s['sum'] ** 2 / s['size']).sum(); den += len(s)
            res[col] = num / den / np.mean(d[col] ** 2)
        print(f"  {name[:40]:40s} W={W:3d} s: n var(mean)/var range {res['zr']:.2f}, bearing {res['zb']:.2f}")
pd.to_pickle(out, outpath('s7_out.pkl'))
