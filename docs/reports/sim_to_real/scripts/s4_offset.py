"""4. The truth's offset (Vicon point vs the robot's rotation centre / camera) and jitter."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
from scipy.signal import savgol_filter

print("## (a) non-holonomic check on the truth alone: the Vicon point's lateral velocity vs turn rate")
print("   a point at (ox, oy) from the axle centre moves laterally at omega*ox and forward at v - omega*oy")
for n in ROBOTS:
    tr = Truth(n)
    t = np.arange(tr.t[0] + 1, tr.t[-1] - 1, 0.05)
    h = 0.1
    xp, yp, thp, ok1 = tr.at(t + h); xm, ym, thm, ok2 = tr.at(t - h); x0, y0, th0, ok3 = tr.at(t)
    ok = ok1 & ok2 & ok3
    vx = (xp - xm) / (2 * h); vy = (yp - ym) / (2 * h); w = (thp - thm) / (2 * h)
    vf = np.cos(th0) * vx + np.sin(th0) * vy; vl = -np.sin(th0) * vx + np.cos(th0) * vy
    m = ok & (np.abs(w) < 2)
    A = np.column_stack([np.ones(m.sum()), w[m]])
    c = np.linalg.lstsq(A, vl[m], rcond=None)[0]
    res = vl[m] - A @ c
    # standard error via blocks of 2 s (40 samples) to respect correlation
    nb = m.sum() // 40; cs = []
    idx = np.where(m)[0][:nb * 40].reshape(nb, 40)
    rng = np.random.default_rng(0)
    for _ in range(200):
        b = idx[rng.integers(0, nb, nb)].ravel()
        cs.append(np.linalg.lstsq(np.column_stack([np.ones(len(b)), w[b]]), vl[b], rcond=None)[0][1])
    # forward: vf vs commanded? (done in s5); here lateral offset oy from vf needs the axle speed
    print(f"robot {n}: lateral v = {100*c[0]:+.2f} cm/s + ox * omega with ox = {100*c[1]:+.2f} cm (block-bootstrap sd {100*np.std(cs):.2f}); "
          f"lateral-velocity sd {100*vl[m].std():.2f} -> {100*res.std():.2f} cm/s; forward-speed rms {100*np.sqrt(np.mean(vf[m]**2)):.1f} cm/s")

print("\n## (b) a camera offset from the Vicon point fitted to the detections' bearings (linearised:")
print("   eb = bias + ox sin(b)/r - oy cos(b)/r + dt * d(bearing)/dt, dt: the shift to add to the stamps; block bootstrap over 10 s blocks for the sd)")
fits = {}
rng = np.random.default_rng(1)
for n in ROBOTS:
    tr = Truth(n)
    d = detections(n, tr=tr)
    d = d[robust_inliers(d.er.values, d.eb.values, d.rt.values)].copy()
    h = 0.05
    dp = detections(n, dt=h, tr=tr).set_index(['t', 'subject']).bt
    dm = detections(n, dt=-h, tr=tr).set_index(['t', 'subject']).bt
    bdot = (wrap(dp - dm) / (2 * h)).reindex(pd.MultiIndex.from_arrays([d.t, d.subject])).values
    ok = np.isfinite(bdot); d = d[ok]; bdot = bdot[ok]
    X = np.column_stack([np.ones(len(d)), np.sin(d.bt) / d.rt, -np.cos(d.bt) / d.rt, -bdot])
    y = d.eb.values
    for label, cols in (('bias', [0]), ('bias+dt', [0, 3]), ('bias+offset', [0, 1, 2]), ('bias+dt+offset', [0, 1, 2, 3])):
        c = np.linalg.lstsq(X[:, cols], y, rcond=None)[0]; r = y - X[:, cols] @ c
        blk = ((d.t.values - d.t.values.min()) // 10).astype(int); ub = np.unique(blk)
        bs = []
        for _ in range(300):
            pick = rng.choice(ub, len(ub)); ii = np.concatenate([np.where(blk == b)[0] for b in pick])
            bs.append(np.linalg.lstsq(X[ii][:, cols], y[ii], rcond=None)[0])
        sd = np.std(bs, axis=0)
        p = dict(zip(cols, zip(c, sd)))
        txt = []
        if 0 in p: txt.append(f"bias {np.degrees(p[0][0]):+.3f}+-{np.degrees(p[0][1]):.3f} deg")
        if 1 in p: txt.append(f"ox {100*p[1][0]:+.2f}+-{100*p[1][1]:.2f} cm, oy {100*p[2][0]:+.2f}+-{100*p[2][1]:.2f} cm")
        if 3 in p: txt.append(f"dt {-p[3][0]:+.4f}+-{p[3][1]:.4f} s")
        print(f"robot {n} [{label}]: " + ", ".join(txt) + f"; bearing sd {np.degrees(y.std()):.3f} -> {np.degrees(r.std()):.3f} deg (var x{r.var()/y.var():.3f})")
        fits[(n, label)] = c
    # the exact (non-linearised) check with the fitted full model
    c = fits[(n, 'bias+dt+offset')]
    d2 = detections(n, dt=-c[3], offset=(c[1], c[2]), tr=tr)
    d2 = d2.set_index(['t', 'subject']).reindex(pd.MultiIndex.from_arrays([d.t, d.subject]))
    e2 = d2.eb.values - c[0]
    print(f"    exact recomputation with the fitted dt and offset: bearing sd {np.degrees(np.nanstd(e2)):.3f} deg")
pd.to_pickle(fits, outpath('s4_fits.pkl'))

print("\n## (c) the truth's jitter: high-frequency residual of the Vicon pose")
for n in ROBOTS:
    g = truth(n)
    t = g.t.values; dtm = np.diff(t)
    # second differences on runs of regular sampling (dt within 10 % of the median)
    med = np.median(dtm)
    reg = (np.abs(dtm[:-1] - med) < 0.1 * med) & (np.abs(dtm[1:] - med) < 0.1 * med)
    out = []
    for col in ('x', 'y', 'th'):
        v = np.unwrap(g[col].values) if col == 'th' else g[col].values
        d2 = v[2:] - 2 * v[1:-1] + v[:-2]
        d2 = d2[reg]
        sig = np.sqrt(np.var(d2) / 6); sig_rob = 1.4826 * np.median(np.abs(d2)) / np.sqrt(6)
        out.append((sig, sig_rob))
    # residual from a Savitzky-Golay smoother over ~0.25 s (15 samples, quadratic)
    x_s = savgol_filter(g.x.values, 15, 2); th_s = savgol_filter(np.unwrap(g.th.values), 15, 2)
    rx = g.x.values - x_s; rth = np.unwrap(g.th.values) - th_s
    # sample-rate
    print(f"robot {n}: rate {1/med:.1f} Hz; white-jitter sd from 2nd differences: x {1000*out[0][0]:.2f} mm (robust {1000*out[0][1]:.2f}), "
          f"y {1000*out[1][0]:.2f} mm (robust {1000*out[1][1]:.2f}), heading {np.degrees(out[2][0]):.3f} deg (robust {np.degrees(out[2][1]):.3f}); "
          f"SG(15,2) residual sd x {1000*rx.std():.2f} mm, heading {np.degrees(rth.std()):.3f} deg; heading steps quantised? unique diffs {len(np.unique(np.round(np.diff(g.th.values),5)))}")
