"""8 (for 7). Which effect makes the twin kinder: a Python EKF like ekf_landmarks (wheel model k per
wheel on velocity odometry, sequential range-bearing updates, chi2 gate 9.21, calibrated noise)
run on the real data and on twin-like synthetic data built on the same true paths, swapping in
one real ingredient or one modelled effect at a time. Scored at 10 Hz against Vicon: position RMS,
fraction of samples with the truth inside the 95 % position ellipse, mean position NEES (2 ideal)."""
import sys, os, math, time; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
B = 0.258; K = 0.040; GATE = 9.21
DT = {1: -0.0333, 2: -0.0298, 3: -0.0351, 4: -0.0352, 5: -0.0258}
OFF = {1: (-0.0286, 0.0107), 2: (0.0004, -0.0057), 3: (-0.0191, -0.0026), 4: (0.0847, 0.0213), 5: (-0.0060, 0.0010)}
BBIAS = {}  # per-robot bearing bias (fitted with dt and offset), rad
L = landmarks(); LPOS = {i: (r.x, r.y) for i, r in L.iterrows()}
TR = {n: Truth(n) for n in ROBOTS}

# ---------- calibration of the twin's noise, as calibrate does (pooled over robots) ----------
d_all = all_detections()
inl = robust_inliers(d_all.er.values, d_all.eb.values, d_all.rt.values)
di = d_all[inl]
def ml_line(x, e):
    from scipy.optimize import minimize
    f = lambda p: np.sum(np.log(np.maximum(p[0] + p[1] * x, 1e-4)) + e ** 2 / (2 * np.maximum(p[0] + p[1] * x, 1e-4) ** 2))
    return minimize(f, [0.02, 0.03], method='Nelder-Mead').x
A = np.column_stack([np.ones(len(di)), di.rt]); BIAS = np.linalg.lstsq(A, di.er, rcond=None)[0]
SPREAD = ml_line(di.rt.values, (di.er - A @ BIAS).values)           # about the bias line (the sensor's)
RMS = ml_line(di.rt.values, di.er.values)                           # about zero (the filter's)
B_BIAS = di.eb.mean(); B_SD = di.eb.std(); B_RMS = np.sqrt(np.mean(di.eb ** 2))
print(f"calibrated: range bias {BIAS[0]:+.4f} {BIAS[1]:+.4f} r, spread {SPREAD[0]:.4f} + {SPREAD[1]:.4f} r; filter sigma_r {RMS[0]:.4f} + {RMS[1]:.4f} r; "
      f"bearing bias {np.degrees(B_BIAS):+.3f} deg sd {np.degrees(B_SD):.3f} rms {np.degrees(B_RMS):.3f}; k {K}")
# depth model per robot (s1b) and its residual spread
DEPTH = {}
for n in ROBOTS:
    g = di[di.robot == n]
    A = np.column_stack([np.ones(len(g)), g.rt * np.cos(g.bt)]); c = np.linalg.lstsq(A, g.r, rcond=None)[0]
    res = g.r.values - A @ c
    DEPTH[n] = (c, ml_line(g.rt.values, res))
    dd = detections(n, dt=DT[n], offset=OFF[n]); BBIAS[n] = dd.eb[robust_inliers(dd.er.values, dd.eb.values, dd.rt.values)].mean()

# ---------- the filter ----------
def run_ekf(n, odo_t, odo_v, odo_w, det, sig_r=RMS, sig_b=B_RMS):
    """det: DataFrame t, subject, r, b (sorted by t). Returns metrics."""
    tr = TR[n]
    t_start = max(odo_t[0], tr.t[0]) + 0.5
    t_end = min(odo_t[-1], tr.t[-1])
    x0, y0, th0, _ = tr.at(np.array([t_start]))
    x, y, th = float(x0[0]), float(y0[0]), float(th0[0])
    P = [[1e-4, 0, 0], [0, 1e-4, 0], [0, 0, (math.radians(1)) ** 2]]
    # events
    ev_t = np.r_[odo_t, det.t.values, np.arange(t_start, t_end, 0.1)]
    ev_k = np.r_[np.zeros(len(odo_t), int), np.ones(len(det), int), np.full(len(np.arange(t_start, t_end, 0.1)), 2)]
    ev_i = np.r_[np.arange(len(odo_t)), np.arange(len(det)), np.arange(len(np.arange(t_start, t_end, 0.1)))]
    order = np.lexsort((ev_k, ev_t)); 
    dr_, db_, ds_ = det.r.values, det.b.values, det.subject.values
    v = w = 0.0; t_last = t_start
    est = []
    acc = rej = 0
    for j in order:
        t = ev_t[j]
        if t < t_start or t > t_end: 
            if ev_k[j] == 0 and t < t_start: v, w = odo_v[ev_i[j]], odo_w[ev_i[j]]
            continue
        dt = t - t_last
        if dt > 0:
            D = v * dt; a = w * dt
            dl = D - a * B / 2; drr = D + a * B / 2
            hm = th + a / 2; c, s = math.cos(hm), math.sin(hm)
            # F P F^T
            f02, f12 = -D * s, D * c
            p00, p01, p02 = P[0]; p10, p11, p12 = P[1]; p20, p21, p22 = P[2]
            a00 = p00 + f02 * p20; a01 = p01 + f02 * p21; a02 = p02 + f02 * p22
            a10 = p10 + f12 * p20; a11 = p11 + f12 * p21; a12 = p12 + f12 * p22
            n00 = a00 + a02 * f02; n01 = a01 + a02 * f12; n02 = a02
            n11 = a11 + a12 * f12; n12 = a12; n22 = p22
            # G Q G^T
            hb = 0.5 / B
            g00 = 0.5 * c + D * s * hb; g01 = 0.5 * c - D * s * hb
            g10 = 0.5 * s - D * c * hb; g11 = 0.5 * s + D * c * hb
            g20 = -1 / B; g21 = 1 / B
            ql = K * K * abs(dl); qr = K * K * abs(drr)
            n00 += g00 * g00 * ql + g01 * g01 * qr; n01 += g00 * g10 * ql + g01 * g11 * qr
            n02 += g00 * g20 * ql + g01 * g21 * qr; n11 += g10 * g10 * ql + g11 * g11 * qr
            n12 += g10 * g20 * ql + g11 * g21 * qr; n22 += g20 * g20 * ql + g21 * g21 * qr
            P = [[n00, n01, n02], [n01, n11, n12], [n02, n12, n22]]
            x += D * c; y += D * s; th += a
            t_last = t
        k = ev_k[j]; i = ev_i[j]
        if k == 0:
            v, w = odo_v[i], odo_w[i]
        elif k == 1:
            lx, ly = LPOS[ds_[i]]
            dx, dy = lx - x, ly - y; q = dx * dx + dy * dy; r = math.sqrt(q)
            zr = dr_[i] - r; zb = (db_[i] - (math.atan2(dy, dx) - th) + math.pi) % (2 * math.pi) - math.pi
            Hm = np.array([[-dx / r, -dy / r, 0], [dy / q, -dx / q, -1]])
            Pm = np.array(P)
            sr = sig_r[0] + sig_r[1] * dr_[i]
            R = np.diag([sr * sr, sig_b * sig_b])
            S = Hm @ Pm @ Hm.T + R
            inn = np.array([zr, zb])
            if inn @ np.linalg.solve(S, inn) < GATE:
                Kg = Pm @ Hm.T @ np.linalg.inv(S)
                dxs = Kg @ inn; x += dxs[0]; y += dxs[1]; th += dxs[2]
                IKH = np.eye(3) - Kg @ Hm
                Pm = IKH @ Pm @ IKH.T + Kg @ R @ Kg.T
                P = Pm.tolist(); acc += 1
            else:
                rej += 1
        else:
            est.append((t, x, y, th, P[0][0], P[0][1], P[1][1], P[2][2]))
    E = np.array(est)
    tx, ty, tth, ok = tr.at(E[:, 0])
    ex, ey = E[:, 1] - tx, E[:, 2] - ty; eth = wrap(E[:, 3] - tth)
    det_ = E[:, 4] * E[:, 6] - E[:, 5] ** 2
    nees = (E[:, 6] * ex * ex - 2 * E[:, 5] * ex * ey + E[:, 4] * ey * ey) / det_
    assert np.isfinite(nees[ok]).all(), 'the filter went non-finite'
    # error in the robot frame (forward, left): a systematic forward offset shows here
    fwd = np.cos(tth) * ex + np.sin(tth) * ey; lft = -np.sin(tth) * ex + np.cos(tth) * ey
    return dict(rms=np.sqrt(np.mean(ex[ok] ** 2 + ey[ok] ** 2)), head=np.degrees(np.sqrt(np.mean(eth[ok] ** 2))),
                inside=np.mean(nees[ok] <= 5.991), nees=np.mean(nees[ok]), fwd=np.mean(fwd[ok]), lft=np.mean(lft[ok]),
                rej=rej / max(acc + rej, 1))

# ---------- ingredients ----------
LAG = pd.read_pickle(outpath('s5_lag.pkl'))     # (robot, 'v'|'omega') -> (var, dead, tau, k, b)
GRID = pd.read_pickle(outpath('s5_grid.pkl'))   # 20 ms grid: commanded and true v, omega
from scipy.signal import lfilter
def first_order(u, dead, tau, H=0.02):
    k = int(round(dead / H)); u = np.r_[np.full(k, u[0]), u[:len(u) - k]] if k > 0 else u
    if tau <= 0: return u
    a = np.exp(-H / tau); return lfilter([1 - a], [1, -a], u, zi=[a * u[0]])[0]

def lagged_real_odo(n):
    """The real command passed through the fitted lag model (dead time, first order, scale, bias):
    what a filter that models the lag would predict with."""
    g = GRID[n]; out = []
    for col, key in (('v', 'v'), ('w', 'omega')):
        _, dead, tau, k, b = LAG[(n, key)]
        out.append(k * first_order(g[col], dead, tau) + b)
    return g['t'], out[0], out[1]

def commanded_sim_odo(n, rng, k=K):
    """A twin whose encoders report the command: the truth's velocity run backwards through the
    robot's fitted lag (cmd = (u(t+d) + tau du/dt(t+d) - b) / k), then the twin's wheel noise."""
    g = GRID[n]; t = g['t']; H = 0.02; res = []
    for col, key in (('tv', 'v'), ('tw', 'omega')):
        _, dead, tau, kk, b = LAG[(n, key)]
        u = np.nan_to_num(g[col]); du = np.gradient(u, H)
        sh = int(round(dead / H))
        c = (u + tau * du - b) / kk
        c = np.r_[c[sh:], np.full(sh, c[-1])]
        res.append(c)
    v, w = res
    dtt = H; D = v * dtt; a = w * dtt
    dl = D - a * B / 2; dr = D + a * B / 2
    dl = dl + rng.normal(0, 1, len(dl)) * k * np.sqrt(np.abs(dl)); dr = dr + rng.normal(0, 1, len(dr)) * k * np.sqrt(np.abs(dr))
    v = (dl + dr) / 2 / dtt; w = (dr - dl) / B / dtt
    v[~g['ok']] = 0; w[~g['ok']] = 0
    return t, v, w

def real_odo(n):
    o = odometry(n); return o.t.values, o.v.values, o.w.values

def sim_odo(n, rng, k=K):
    """The twin's encoders: the true wheel travel between the readings plus N(0, k^2 |d|) per wheel."""
    o = odometry(n); t = o.t.values; tr = TR[n]
    x, y, th, ok = tr.at(t)
    dx, dy = np.diff(x), np.diff(y); dth = np.diff(th); hm = th[:-1] + dth / 2
    D = dx * np.cos(hm) + dy * np.sin(hm); a = dth
    dl = D - a * B / 2; dr = D + a * B / 2
    dl = dl + rng.normal(0, 1, len(dl)) * k * np.sqrt(np.abs(dl)); dr = dr + rng.normal(0, 1, len(dr)) * k * np.sqrt(np.abs(dr))
    dtt = np.diff(t); good = ok[:-1] & ok[1:] & np.isfinite(dl) & (dtt > 1e-6)
    dtt = np.where(dtt > 1e-6, dtt, 1.0)
    v = np.where(good, (dl + dr) / 2 / dtt, 0.0); w = np.where(good, (dr - dl) / B / dtt, 0.0)
    return t, np.r_[v, 0.0], np.r_[w, 0.0]

def real_det(n, correct=()):
    m = measurements(n); m = m[m.subject.isin(L.index)].copy().sort_values('t')
    if 'depth' in correct or 'bbias' in correct:
        # the filter given corrected detections: range mapped back through the per-robot depth model
        # (an estimate of the true range from r_meas and the measured bearing), bearing less its bias
        if 'depth' in correct:
            c, _ = DEPTH[n]; m['r'] = (m.r - c[0]) / c[1] / np.cos(m.b)
        if 'bbias' in correct: m['b'] = m.b - BBIAS[n]
    if 'dt' in correct: m['t'] = m.t + DT[n]
    return m[['t', 'subject', 'r', 'b']]

def gm(times, comps, rng):
    """Sum of white noise and first-order components: comps = [(var, tau)], the rest white."""
    z = np.zeros(len(times)); white = 1 - sum(a for a, _ in comps)
    for a, tau in comps:
        s = np.zeros(len(times)); prev = None
        e = rng.normal(0, 1, len(times))
        for i, t in enumerate(times):
            s[i] = e[i] if prev is None else math.exp(-(t - prev[0]) / tau) * prev[1] + math.sqrt(1 - math.exp(-2 * (t - prev[0]) / tau)) * e[i]
            prev = (t, s[i])
        z += math.sqrt(a) * s
    return z + math.sqrt(max(white, 0)) * rng.normal(0, 1, len(times))

TWIN_R = [(1.0, 1.4)]; TWIN_B = [(1.0, 1.4)]                                  # calibrate's tau 1.4 s
SLOW_R = [(0.71, 3.4), (0.28, 76.0)]; SLOW_B = [(0.21, 3.7), (0.38, 74.0)]      # s2, calibrate-defined errors
SLOW_RC = [(0.23, 0.47), (0.39, 11.0)]; SLOW_BC = [(0.29, 6.3), (0.16, 70.0)]   # s2, after depth model + dt

def sim_det(n, times_ids, rng, effects=()):
    """Synthetic detections at the given (t, subject): the truth + the twin's noise model, or with effects."""
    d = times_ids.copy().sort_values('t'); tr = TR[n]
    dt = DT[n] if 'dt' in effects else 0.0
    off = OFF[n] if 'offset' in effects else (0.0, 0.0)
    x, y, th, ok = tr.at(d.t.values + dt)
    x = x + np.cos(th) * off[0] - np.sin(th) * off[1]; y = y + np.sin(th) * off[0] + np.cos(th) * off[1]
    lx = L.loc[d.subject, 'x'].values; ly = L.loc[d.subject, 'y'].values
    rt = np.hypot(lx - x, ly - y); bt = wrap(np.arctan2(ly - y, lx - x) - th)
    zr = np.zeros(len(d)); zb = np.zeros(len(d))
    if 'depth' in effects: cr, cb = SLOW_RC, SLOW_BC
    elif 'slow' in effects: cr, cb = SLOW_R, SLOW_B
    else: cr, cb = TWIN_R, TWIN_B
    for s in d.subject.unique():
        m = (d.subject == s).values
        zr[m] = gm(d.t.values[m], cr, rng); zb[m] = gm(d.t.values[m], cb, rng)
    if 'depth' in effects:
        c, sp = DEPTH[n]
        r = c[0] + c[1] * rt * np.cos(bt) + zr * np.maximum(sp[0] + sp[1] * rt, 0.003)
        bsd = np.degrees(1) and np.std(detections(n, dt=DT[n], offset=OFF[n]).eb)  # per-robot spread after dt/offset
        bsd = min(bsd, B_SD)
    else:
        r = rt + BIAS[0] + BIAS[1] * rt + zr * (SPREAD[0] + SPREAD[1] * rt)
        bsd = B_SD
    b = bt + (BBIAS[n] if 'bbias' in effects else B_BIAS) + zb * bsd
    d['r'] = r; d['b'] = wrap(b)
    return d[ok][['t', 'subject', 'r', 'b']]

V = pd.read_pickle(outpath('s6_visible.pkl'))
def iid_times(n, rng):
    """The twin's visibility: every rebuilt camera frame, each landmark in view detected with the robot's mean rate."""
    g = V[V.robot == n]; p = g.det.mean()
    keep = rng.random(len(g)) < p
    return g[keep][['t', 'lm']].rename(columns={'lm': 'subject'})

def real_times(n):
    return real_det(n)[['t', 'subject']]

CONFIGS = [
    # name, odometry, detection times, detection values
    ('REAL: real odometry, real detections', 'real', 'real', 'real', ()),
    ('real, detections corrected: depth model', 'real', 'real', 'real', ('depth',)),
    ('real, corrected: depth + bearing bias', 'real', 'real', 'real', ('depth', 'bbias')),
    ('real, corrected: depth + bearing bias + time shift', 'real', 'real', 'real', ('depth', 'bbias', 'dt')),
    ('real, corrected: time shift only', 'real', 'real', 'real', ('dt',)),
    ('TWIN-LIKE: sim odometry, iid visibility, twin noise', 'sim', 'iid', 'sim', ()),
    ('sim odometry, real visibility, twin noise', 'sim', 'real', 'sim', ()),
    ('real odometry, real visibility, twin noise', 'real', 'real', 'sim', ()),
    ('sim odometry, real visibility, real detections', 'sim', 'real', 'real', ()),
    ('real odometry, iid visibility, twin noise', 'real', 'iid', 'sim', ()),
    ('sim odo, real vis, + slow correlation (2 exp)', 'sim', 'real', 'sim', ('slow',)),
    ('sim odo, real vis, + depth model (+its corr.)', 'sim', 'real', 'sim', ('depth',)),
    ('sim odo, real vis, + time shift', 'sim', 'real', 'sim', ('dt',)),
    ('sim odo, real vis, + camera offset + robot bearing bias', 'sim', 'real', 'sim', ('offset', 'bbias')),
    ('sim odo, real vis, + depth + dt + offset + bbias', 'sim', 'real', 'sim', ('depth', 'dt', 'offset', 'bbias')),
    ('real odo, real vis, + depth + dt + offset + bbias', 'real', 'real', 'sim', ('depth', 'dt', 'offset', 'bbias')),
    ('real odometry through the fitted lag, real detections', 'lagged', 'real', 'real', ()),
    ('real odometry through the fitted lag, detections corrected (depth+bbias+dt)', 'lagged', 'real', 'real', ('depth', 'bbias', 'dt')),
    ('TWIN + commanded odometry (inverse lag + wheel noise), iid vis, twin noise', 'cmdsim', 'iid', 'sim', ()),
    ('TWIN + commanded odometry, iid vis, + depth + dt + offset + bbias', 'cmdsim', 'iid', 'sim', ('depth', 'dt', 'offset', 'bbias')),
    ('TWIN + commanded odometry, real vis, + depth + dt + offset + bbias', 'cmdsim', 'real', 'sim', ('depth', 'dt', 'offset', 'bbias')),
    ('TWIN-LIKE, iid vis, + depth + dt + offset + bbias', 'sim', 'iid', 'sim', ('depth', 'dt', 'offset', 'bbias')),
]
SEEDS = [1, 2, 3, 4, 5, 6]
only = sys.argv[1:] and [int(a) for a in sys.argv[1:]]
results = []
t0 = time.time()
for ci, (name, odo, vis, val, eff) in enumerate(CONFIGS):
    if only and ci not in only: continue
    random_cfg = odo in ('sim', 'cmdsim') or vis == 'iid' or val == 'sim'
    for seed in (SEEDS if random_cfg else [0]):
        for n in ROBOTS:
            rng = np.random.default_rng(1000 * seed + n)
            ot, ov, ow = {'real': lambda: real_odo(n), 'sim': lambda: sim_odo(n, rng), 'lagged': lambda: lagged_real_odo(n),
                          'cmdsim': lambda: commanded_sim_odo(n, rng)}[odo]()
            times = real_times(n) if vis == 'real' else iid_times(n, rng)
            det = real_det(n, eff) if val == 'real' else sim_det(n, times, rng, eff)
            det = det.sort_values('t')
            m = run_ekf(n, ot, ov, ow, det)
            m.update(config=name, seed=seed, robot=n); results.append(m)
    R = pd.DataFrame([r for r in results if r['config'] == name])
    print(f"[{time.time()-t0:5.0f} s] {name:58s} RMS {R.rms.mean():.3f} m (median {R.rms.median():.3f}) (robots {', '.join(f'{x:.3f}' for x in R.groupby('robot').rms.mean())}); "
          f"heading {R['head'].mean():.2f} deg; truth in 95 % ellipse {100*R.inside.mean():.0f} %; NEES {R.nees.mean():.1f}; fwd bias {100*R.fwd.mean():+.1f} cm; rejected {100*R.rej.mean():.1f} %", flush=True)
pd.DataFrame(results).to_csv(outpath('s8_results%s.csv' % ('' if not only else '_' + '_'.join(map(str, only)))), index=False)
