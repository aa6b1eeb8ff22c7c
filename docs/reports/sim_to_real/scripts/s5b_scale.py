"""5b. Per-robot overall scale of the commanded v and omega against the truth (sums over the run)."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
G = pd.read_pickle(outpath('s5_grid.pkl')); LAG = pd.read_pickle(outpath('s5_lag.pkl'))
from scipy.signal import lfilter
H = 0.02
def first_order(u, dead, tau):
    k = int(round(dead / H)); u = np.r_[np.full(k, u[0]), u[:len(u) - k]] if k > 0 else u
    if tau <= 0: return u
    a = np.exp(-H / tau); return lfilter([1 - a], [1, -a], u, zi=[a * u[0]])[0]
for n in ROBOTS:
    g = G[n]; ok = g['ok']
    sv = g['tv'][ok].sum() / g['v'][ok].sum()
    # turn: signed left and right separately
    _, dw, tw_, _, _ = LAG[(n, 'omega')]; wl = first_order(g['w'], dw, tw_)
    L = ok & (wl > 0.01); R = ok & (wl < -0.01)
    sl = g['tw'][L].sum() / wl[L].sum(); sr = g['tw'][R].sum() / wl[R].sum()
    z = ok & (g['w'] == 0)
    stop = ok & (g['v'] == 0) & (g['w'] == 0)
    print(f"robot {n}: distance true/commanded {sv:.3f}; turn true/(lag-filtered command) left {sl:.3f}, right {sr:.3f}; "
          f"true turn rate while commanded 0: mean {np.degrees(g['tw'][z].mean()):+.2f} deg/s sd {np.degrees(g['tw'][z].std()):.2f}; "
          f"true speed while commanded stop: mean {100*g['tv'][stop].mean():+.2f} cm/s ({stop.mean()*100:.0f} % of time); "
          f"commanded v values: {np.unique(np.round(g['v'][ok],3))[:8]}")
