"""2. Time correlation of detection errors per (robot, landmark): autocorrelation vs lag, 1 vs 2 exponentials."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
from scipy.optimize import curve_fit
DT = {1: -0.0333, 2: -0.0298, 3: -0.0351, 4: -0.0352, 5: -0.0258}   # s4 (b), bias+dt+offset

def errors(corrected):
    out = []
    for n in ROBOTS:
        d = detections(n, dt=DT[n] if corrected else 0.0)
        d = d[robust_inliers(d.er.values, d.eb.values, d.rt.values)].copy()
        out.append(d)
    d = pd.concat(out, ignore_index=True)
    if not corrected:   # calibrate's model: range bias and spread lines pooled, bearing bias pooled
        A = np.column_stack([np.ones(len(d)), d.rt]); c = np.linalg.lstsq(A, d.er, rcond=None)[0]
        res = d.er - A @ c
        s = np.linalg.lstsq(A, np.abs(res) * np.sqrt(np.pi / 2), rcond=None)[0]
        d['zr'] = res / (A @ s); d['zb'] = (d.eb - d.eb.mean()) / d.eb.std()
    else:               # per robot: depth model for range (a + k r cos b), bearing bias per robot
        zr = np.empty(len(d)); zb = np.empty(len(d))
        for n in ROBOTS:
            m = (d.robot == n).values; g = d[m]
            A = np.column_stack([np.ones(m.sum()), g.rt * np.cos(g.bt)]); c = np.linalg.lstsq(A, g.r, rcond=None)[0]
            res = g.r.values - A @ c
            B = np.column_stack([np.ones(m.sum()), g.rt]); s = np.linalg.lstsq(B, np.abs(res) * np.sqrt(np.pi / 2), rcond=None)[0]
            zr[m] = res / (B @ s); zb[m] = (g.eb - g.eb.mean()) / g.eb.std()
        d['zr'] = zr; d['zb'] = zb
    return d

EDGES = np.r_[0, np.geomspace(0.05, 60, 28)]
def acf(d, col, robots=ROBOTS):
    num = np.zeros(len(EDGES) - 1); cnt = np.zeros(len(EDGES) - 1)
    for (n, l), g in d[d.robot.isin(robots)].groupby(['robot', 'subject']):
        t = g.t.values; z = g[col].values
        i, j = np.triu_indices(len(t), 1)
        lag = t[j] - t[i]; keep = lag <= 60
        b = np.digitize(lag[keep], EDGES) - 1
        ok = (b >= 0) & (b < len(num))
        np.add.at(num, b[ok], (z[i] * z[j])[keep][ok]); np.add.at(cnt, b[ok], 1)
    var = np.mean(d[d.robot.isin(robots)][col] ** 2)
    mid = np.sqrt(EDGES[:-1] * EDGES[1:]); mid[0] = 0.025
    return mid, num / np.maximum(cnt, 1) / var, cnt

def one(x, a, tau): return a * np.exp(-x / tau)
def one_c(x, a, tau, c): return a * np.exp(-x / tau) + c
def two(x, a1, t1, a2, t2): return a1 * np.exp(-x / t1) + a2 * np.exp(-x / t2)

results = {}
for corrected in (False, True):
    d = errors(corrected)
    label = 'after the depth model and the time shift (per robot)' if corrected else "as calibrate defines them (pooled bias/spread lines)"
    print(f"\n## errors {label}")
    for col in ('zr', 'zb'):
        for rob in (ROBOTS,) + tuple([r] for r in ROBOTS):
            x, rho, cnt = acf(d, col, rob)
            m = (cnt >= 30) & (x >= 0.1) & (x <= 30)
            w = 1 / np.sqrt(cnt[m])
            name = 'pooled' if len(rob) > 1 else f'robot {rob[0]}'
            try:
                p1, _ = curve_fit(one, x[m], rho[m], p0=[0.8, 1.5], sigma=w, bounds=([0, 0.01], [1.5, 1000]))
                p1c, _ = curve_fit(one_c, x[m], rho[m], p0=[0.6, 1.0, 0.1], sigma=w, bounds=([0, 0.01, -0.5], [1.5, 1000, 1]))
                p2, _ = curve_fit(two, x[m], rho[m], p0=[0.5, 0.5, 0.3, 10], sigma=w, bounds=([0, 0.01, 0, 0.5], [1.5, 50, 1.5, 1000]))
            except Exception as e:
                print(name, col, 'fit failed', e); continue
            if p2[1] > p2[3]: p2 = np.r_[p2[2:], p2[:2]]
            r1 = np.sum(((rho[m] - one(x[m], *p1)) / w) ** 2); r2 = np.sum(((rho[m] - two(x[m], *p2)) / w) ** 2)
            rc = np.sum(((rho[m] - one_c(x[m], *p1c)) / w) ** 2)
            if len(rob) > 1 or True:
                results[(corrected, col, name)] = (x, rho, cnt, p1, p2, p1c)
            print(f"{col} {name}: rho(0.1-0.2 s) {rho[(x>0.1)&(x<0.2)].mean():.2f}, (1 s) {np.interp(1, x[m], rho[m]):.2f}, (5 s) {np.interp(5, x[m], rho[m]):.2f}, (20 s) {np.interp(20, x[m], rho[m]):.2f}; "
                  f"1 exp: {p1[0]:.2f} e^(-t/{p1[1]:.2f}) [wsse {r1:.0f}]; 1 exp + const: {p1c[0]:.2f} e^(-t/{p1c[1]:.2f}) + {p1c[2]:.2f} [wsse {rc:.0f}]; "
                  f"2 exp: {p2[0]:.2f} e^(-t/{p2[1]:.2f}) + {p2[2]:.2f} e^(-t/{p2[3]:.1f}) [wsse {r2:.0f}]; nugget (white) {1 - p2[0] - p2[2]:.2f}")
    if not corrected:
        print("\nlag table (pooled): lag [s], pairs, rho_range, rho_bearing")
        x, rr, c = results[(False, 'zr', 'pooled')][:3]; _, rb, _ = results[(False, 'zb', 'pooled')][:3]
        for a, b_, cc, e in zip(x, rr, c, rb):
            if cc >= 30: print(f"  {a:7.3f} {int(cc):7d} {b_:6.3f} {e:6.3f}")
    else:
        print("\nlag table (pooled, corrected): lag [s], pairs, rho_range, rho_bearing")
        x, rr, c = results[(True, 'zr', 'pooled')][:3]; _, rb, _ = results[(True, 'zb', 'pooled')][:3]
        for a, b_, cc, e in zip(x, rr, c, rb):
            if cc >= 30: print(f"  {a:7.3f} {int(cc):7d} {b_:6.3f} {e:6.3f}")
pd.to_pickle(results, outpath('s2_acf.pkl'))
