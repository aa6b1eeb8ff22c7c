"""5. Commanded-velocity odometry against the truth: lag, scale/bias, error growth with interval."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
from scipy.signal import lfilter
H = 0.02  # grid step [s]

def grid(n):
    tr = Truth(n); o = odometry(n)
    t0 = max(tr.t[0], o.t.values[0]) + 1; t1 = min(tr.t[-1], o.t.values[-1]) - 1
    t = np.arange(t0, t1, H)
    i = np.searchsorted(o.t.values, t, side='right') - 1        # zero-order hold of the command
    v = o.v.values[i]; w = o.w.values[i]
    x, y, th, ok = tr.at(t)
    # truth velocities by central differences over +-0.06 s
    h = 0.06
    xp, yp, thp, o1 = tr.at(t + h); xm, ym, thm, o2 = tr.at(t - h)
    vx = (xp - xm) / (2*h); vy = (yp - ym) / (2*h)
    tv = np.cos(th) * vx + np.sin(th) * vy; tw = (thp - thm) / (2*h)
    ok &= o1 & o2
    # the odometry's gaps: a command older than 1.1 s is stale
    ok &= (t - o.t.values[i]) < 1.1
    return dict(t=t, v=v, w=w, x=x, y=y, th=th, tv=tv, tw=tw, ok=ok)

def first_order(u, dead, tau):
    k = int(round(dead / H))
    u = np.r_[np.full(k, u[0]), u[:len(u) - k]] if k > 0 else u
    if tau <= 0: return u
    a = np.exp(-H / tau)
    return lfilter([1 - a], [1, -a], u, zi=[a * u[0]])[0]

G = {n: grid(n) for n in ROBOTS}
pd.to_pickle(G, outpath('s5_grid.pkl'))
print("## lag: cross-correlation of commanded and true velocity (peak lag), and a dead-time + first-order fit")
lagfit = {}
for n in ROBOTS:
    g = G[n]; ok = g['ok']
    out = []
    for cmd, true, name in ((g['v'], g['tv'], 'v'), (g['w'], g['tw'], 'omega')):
        c = cmd - cmd[ok].mean(); tt = true - true[ok].mean()
        lags = np.arange(0, 101)  # 0..2 s
        cc = []
        for L in lags:
            m = ok[L:] & ok[:len(ok) - L]
            cc.append(np.corrcoef(c[:len(c) - L][m], tt[L:][m])[0, 1])
        cc = np.array(cc); Lp = lags[np.argmax(cc)] * H
        # dead time + first-order: grid, with a scale and offset fitted by least squares
        best = None
        for dead in np.arange(0, 0.61, 0.02):
            for tau in (0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.7, 1.0):
                f = first_order(cmd, dead, tau)
                A = np.column_stack([f[ok], np.ones(ok.sum())])
                k, b = np.linalg.lstsq(A, true[ok], rcond=None)[0]
                r = true[ok] - A @ [k, b]
                if best is None or r.var() < best[0]: best = (r.var(), dead, tau, k, b)
        A = np.column_stack([cmd[ok], np.ones(ok.sum())]); k0, b0 = np.linalg.lstsq(A, true[ok], rcond=None)[0]
        r0 = true[ok] - A @ [k0, b0]
        out.append((name, Lp, cc.max(), cc[0], best, k0, b0, r0.var()))
        lagfit[(n, name)] = best
    for name, Lp, cmax, c0, best, k0, b0, v0 in out:
        unit = 'm/s' if name == 'v' else 'rad/s'
        print(f"robot {n} {name}: xcorr peak at {Lp:.2f} s (r {cmax:.3f}; at 0 s {c0:.3f}); no lag: true = {k0:.3f} cmd {b0:+.4f} {unit}, resid sd {np.sqrt(v0):.4f}; "
              f"best dead {best[1]:.2f} s + tau {best[2]:.2f} s: true = {best[3]:.3f} cmd {best[4]:+.4f}, resid sd {np.sqrt(best[0]):.4f} (var x{best[0]/v0:.2f})")
pd.to_pickle(lagfit, outpath('s5_lag.pkl'))

def increments(g, T, lag=None, offset=0.0, step=0.5):
    """Integrate the command over [t, t+T] from the true start pose; errors (forward, lateral, heading)
    of the end pose in the start frame against the truth. offset: the axle centre is at the Vicon
    point + offset forward (so the truth is moved to the axle before comparing)."""
    n = int(round(T / H)); s = int(round(step / H))
    v, w = g['v'], g['w']
    if lag is not None:
        (_, dv, tv_, kv, bv), (_, dw, tw_, kw, bw) = lag
        v = kv * first_order(v, dv, tv_) + bv; w = kw * first_order(w, dw, tw_) + bw
    th = g['th']; x = g['x'] + offset * np.cos(th); y = g['y'] + offset * np.sin(th)
    okc = np.cumsum(~g['ok'])
    idx = np.arange(0, len(x) - n - 1, s)
    idx = idx[okc[idx + n] - okc[idx] == 0]
    E = []
    # integrate: heading and position relative (exact arcs not needed at 20 ms)
    for i in idx:
        ths = th[i] + np.r_[0, np.cumsum(w[i:i+n] * H)]
        px = np.sum(v[i:i+n] * np.cos(ths[:-1] + 0.5 * w[i:i+n] * H) * H)
        py = np.sum(v[i:i+n] * np.sin(ths[:-1] + 0.5 * w[i:i+n] * H) * H)
        dxw, dyw = x[i+n] - x[i], y[i+n] - y[i]
        c, s_ = np.cos(th[i]), np.sin(th[i])
        ex = c * (px - dxw) + s_ * (py - dyw); ey = -s_ * (px - dxw) + c * (py - dyw)
        eth = wrap(ths[-1] - th[i+n])
        E.append((ex, ey, eth, np.hypot(dxw, dyw)))
    return np.array(E)

Ts = [0.1, 0.25, 0.5, 1, 2, 5, 10, 20]
print("\n## error growth with the interval (command integrated from the true start pose); var per robot and pooled")
print("   columns: T, var forward [cm^2], lateral [cm^2], heading [deg^2], and var(T)/(T/0.5 * var(0.5)) (1: independent steps)")
res = {}
for label, lagged in (('raw command', False), ('command through the fitted lag (dead time + first order, scale, bias)', True)):
    print(f"### {label}")
    for n in ROBOTS + ['pooled']:
        rows = []
        for T in Ts:
            if n == 'pooled':
                E = np.concatenate([increments(G[k], T, lag=(lagfit[(k, 'v')], lagfit[(k, 'omega')]) if lagged else None) for k in ROBOTS])
            else:
                E = increments(G[n], T, lag=(lagfit[(n, 'v')], lagfit[(n, 'omega')]) if lagged else None)
            rows.append((T, 1e4 * E[:, 0].var(), 1e4 * E[:, 1].var(), np.degrees(1)**2 * E[:, 2].var(), E[:, 0].mean(), np.degrees(E[:, 2].mean()), len(E)))
        rows = np.array(rows)
        res[(label, n)] = rows
        r05 = rows[Ts.index(0.5)]
        txt = "; ".join(f"T={r[0]:g}: {r[1]:.2f}, {r[2]:.2f}, {r[3]:.2f} ({r[1]/(r[0]/0.5*r05[1]):.2f}/{r[3]/(r[0]/0.5*r05[3]):.2f})" for r in rows)
        print(f"robot {n}: {txt}")
pd.to_pickle(res, outpath('s5_growth.pkl'))

print("\n## slope of log var vs log T between 0.5 and 5 s (1: random walk of independent steps; 2: a constant rate error; <1: bounded)")
for key, rows in res.items():
    if key[1] != 'pooled': continue
    i, j = Ts.index(0.5), Ts.index(5)
    sl = [np.log(rows[j, c] / rows[i, c]) / np.log(10) for c in (1, 2, 3)]
    print(f"{key[0]}: forward {sl[0]:.2f}, lateral {sl[1]:.2f}, heading {sl[2]:.2f}")

print("\n## the axle offset: forward increment error with the truth moved to the axle (offset from s4a, ~ +1 cm)")
for n, off in zip(ROBOTS, (0.0136, 0.0100, 0.0101, 0.0069, 0.0070)):
    for T in (0.5, 2):
        E0 = increments(G[n], T, lag=(lagfit[(n, 'v')], lagfit[(n, 'omega')]))
        E1 = increments(G[n], T, lag=(lagfit[(n, 'v')], lagfit[(n, 'omega')]), offset=off)
        print(f"robot {n} T={T}: lagged-command error var fwd/lat [cm^2] at Vicon point {1e4*E0[:,0].var():.3f}/{1e4*E0[:,1].var():.3f}, at the axle {1e4*E1[:,0].var():.3f}/{1e4*E1[:,1].var():.3f}")
