"""3. Time stamp offsets: detections vs truth (bearing error variance over dt), odometry vs truth."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
dts = np.round(np.arange(-0.5, 0.5001, 0.01), 3)
inl_ref = pd.read_pickle(outpath('det_all.pkl'))
res = {}
for n in ROBOTS + ['pooled']:
    rob = ROBOTS if n == 'pooled' else [n]
    trs = {k: Truth(k) for k in rob}
    base = pd.concat([detections(k, tr=trs[k]) for k in rob], ignore_index=True)
    inl = robust_inliers(base.er.values, base.eb.values, base.rt.values)
    keys = set(zip(base.robot[inl], base.t[inl], base.subject[inl]))
    v_b, v_r = [], []
    for dt in dts:
        d = pd.concat([detections(k, dt=dt, tr=trs[k]) for k in rob], ignore_index=True)
        d = d[[k in keys for k in zip(d.robot, d.t, d.subject)]]
        # bearing error about each robot's mean; range about the depth model a + k r cos b (per robot)
        eb = d.eb - d.groupby('robot').eb.transform('mean')
        er = []
        for k, g in d.groupby('robot'):
            A = np.column_stack([np.ones(len(g)), g.rt * np.cos(g.bt)])
            c = np.linalg.lstsq(A, g.r, rcond=None)[0]; er.append(g.r - A @ c)
        v_b.append(eb.var()); v_r.append(pd.concat(er).var())
    v_b = np.array(v_b); v_r = np.array(v_r)
    i = np.argmin(v_b); j = np.argmin(v_r)
    # parabola refinement of the bearing minimum
    if 0 < i < len(dts) - 1:
        y0, y1, y2 = v_b[i-1:i+2]; off = 0.5 * (y0 - y2) / (y0 - 2*y1 + y2); dtb = dts[i] + off * 0.01
    else: dtb = dts[i]
    print(f"robot {n}: bearing-var min at dt = {dtb:+.3f} s: sd {np.degrees(np.sqrt(v_b[i])):.3f} deg vs {np.degrees(np.sqrt(v_b[50])):.3f} at dt=0 "
          f"(var ratio {v_b[i]/v_b[50]:.3f}); range-var (depth model) min at dt = {dts[j]:+.2f} s: sd {100*np.sqrt(v_r[j]):.2f} vs {100*np.sqrt(v_r[50]):.2f} cm")
    res[n] = (dts, v_b, v_r)
    # regression on the truth's rotation rate at dt=0 (eb ~ -omega dt)
    d0 = base[inl]
    for k in rob:
        pass
pd.to_pickle(res, outpath('s3_det_dt.pkl'))

print("\n## bearing error against the truth's turn rate (dt = 0): slope = -dt")
for n in ROBOTS:
    tr = Truth(n); d = detections(n, tr=tr)
    d = d[robust_inliers(d.er.values, d.eb.values, d.rt.values)]
    h = 0.05
    _, _, tp, ok1 = tr.at(d.t.values + h); _, _, tm, ok2 = tr.at(d.t.values - h)
    w = (tp - tm) / (2 * h); ok = ok1 & ok2
    # also the bearing change due to translation: d(bt)/dt from the truth geometry
    dp = detections(n, dt=h, tr=tr).set_index(['t', 'subject']).bt
    dm = detections(n, dt=-h, tr=tr).set_index(['t', 'subject']).bt
    d = d.set_index(['t', 'subject'])
    bdot = (wrap(dp - dm) / (2 * h)).reindex(d.index).values
    ok &= np.isfinite(bdot)
    eb = d.eb.values[ok] - d.eb.values[ok].mean()
    A = np.column_stack([np.ones(ok.sum()), bdot[ok]])
    c = np.linalg.lstsq(A, d.eb.values[ok], rcond=None)[0]
    cw = np.polyfit(w[ok], d.eb.values[ok], 1)
    r = d.eb.values[ok] - A @ c
    print(f"robot {n}: eb = {np.degrees(c[0]):+.3f} deg + {c[1]:+.4f} s * d(bearing)/dt  -> dt = {c[1]:+.3f} s (bearing sd {np.degrees(d.eb.values[ok].std()):.3f} -> {np.degrees(r.std()):.3f} deg); "
          f"on turn rate only: dt = {-cw[0]:+.3f} s; |turn rate| rms at detections {np.sqrt(np.mean(w[ok]**2)):.3f} rad/s")
