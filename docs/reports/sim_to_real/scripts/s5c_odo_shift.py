"""5c / 3. A pure time shift of the odometry stamps against the truth: the shift that minimises the
error of 0.5 s and 2 s command-integrated increments (no lag model, no scale)."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
G = pd.read_pickle(outpath('s5_grid.pkl')); H = 0.02
def incr_err(g, T, shift):
    k = int(round(shift / H)); n = int(round(T / H))
    v, w = g['v'], g['w']
    if k > 0: v = np.r_[np.full(k, v[0]), v[:-k]]; w = np.r_[np.full(k, w[0]), w[:-k]]   # command applied k steps later
    elif k < 0: v = np.r_[v[-k:], np.full(-k, v[-1])]; w = np.r_[w[-k:], np.full(-k, w[-1])]
    cw = np.r_[0, np.cumsum(w * H)]; okc = np.cumsum(~g['ok'])
    idx = np.arange(0, len(v) - n - 1, 10); idx = idx[okc[idx + n] - okc[idx] == 0]
    dth_cmd = cw[idx + n] - cw[idx]; dth_true = g['th'][idx + n] - g['th'][idx]
    # forward distance: commanded sum of v vs true chord projected (short T: fine)
    cv = np.r_[0, np.cumsum(v * H)]
    dd_true = np.hypot(g['x'][idx + n] - g['x'][idx], g['y'][idx + n] - g['y'][idx])
    return np.var(dth_cmd - dth_true), np.var(cv[idx + n] - cv[idx] - dd_true)
shifts = np.round(np.arange(-0.5, 0.501, 0.02), 2)
for n in ROBOTS:
    out = []
    for T in (0.5, 2.0):
        vh = np.array([incr_err(G[n], T, s) for s in shifts])
        i = np.argmin(vh[:, 0]); j = np.argmin(vh[:, 1]); z = list(shifts).index(0.0)
        out.append(f"T={T}: heading-error var min at command delayed {shifts[i]:+.2f} s (x{vh[i,0]/vh[z,0]:.2f} of unshifted), distance-error var min at {shifts[j]:+.2f} s (x{vh[j,1]/vh[z,1]:.2f})")
    print(f"robot {n}: " + "; ".join(out))
