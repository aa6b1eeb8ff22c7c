"""Shared loading for the sim-to-real measurements on MRCLAM Dataset 6."""
import numpy as np, pandas as pd, os, sys
_DATA_HELP = ("Get MRCLAM Dataset 6 from the UTIAS Multi-Robot Cooperative Localization and Mapping "
              "benchmark, http://asrl.utias.utoronto.ca/datasets/mrclam/, extract it, and set MRCLAM_DIR "
              "to the extracted MRCLAM_Dataset6 folder (the one that holds Barcodes.dat and Robot1_Odometry.dat).")
D = os.environ.get('MRCLAM_DIR', '')
if not D:
    sys.exit("MRCLAM_DIR is not set. " + _DATA_HELP)
if not os.path.isfile(os.path.join(D, 'Barcodes.dat')):
    sys.exit(f"MRCLAM_DIR={D} holds no Barcodes.dat. " + _DATA_HELP)
# intermediate outputs (pickle caches, s8_results.csv): S2R_OUT, by default a folder 'out' beside the scripts
OUT = os.environ.get('S2R_OUT') or os.path.join(os.path.dirname(os.path.abspath(__file__)), 'out')
os.makedirs(OUT, exist_ok=True)

def outpath(name):
    return os.path.join(OUT, name)

ROBOTS = [1, 2, 3, 4, 5]
MAX_GAP = 0.1  # s: truth samples farther apart are a break (no interpolation)

def _read(name, cols):
    return pd.read_csv(os.path.join(D, name), comment='#', sep=r'\s+', header=None, names=cols)

def barcodes():
    b = _read('Barcodes.dat', ['subject', 'barcode'])
    return dict(zip(b.barcode, b.subject))

def landmarks():
    l = _read('Landmark_Groundtruth.dat', ['subject', 'x', 'y', 'xsd', 'ysd'])
    return l.set_index('subject')

def truth(n):
    return _read(f'Robot{n}_Groundtruth.dat', ['t', 'x', 'y', 'th'])

def odometry(n):
    return _read(f'Robot{n}_Odometry.dat', ['t', 'v', 'w'])

def measurements(n):
    m = _read(f'Robot{n}_Measurement.dat', ['t', 'barcode', 'r', 'b'])
    m['subject'] = m.barcode.map(barcodes()).fillna(-1).astype(int)
    return m

def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi

class Truth:
    """Linear interpolation of a robot's Vicon pose (heading unwrapped), none across gaps."""
    def __init__(self, n, max_gap=MAX_GAP):
        g = truth(n)
        g = g.drop_duplicates('t')
        self.t = g.t.values; self.x = g.x.values; self.y = g.y.values
        self.th = np.unwrap(g.th.values)
        self.max_gap = max_gap
    def at(self, t):
        t = np.asarray(t, float)
        i = np.searchsorted(self.t, t)
        ok = (i > 0) & (i < len(self.t))
        i = np.clip(i, 1, len(self.t) - 1)
        t0, t1 = self.t[i - 1], self.t[i]
        ok &= (t1 - t0) <= self.max_gap
        u = np.where(t1 > t0, (t - t0) / np.maximum(t1 - t0, 1e-12), 0)
        x = self.x[i - 1] + u * (self.x[i] - self.x[i - 1])
        y = self.y[i - 1] + u * (self.y[i] - self.y[i - 1])
        th = self.th[i - 1] + u * (self.th[i] - self.th[i - 1])
        return x, y, th, ok

def detections(n, dt=0.0, offset=(0.0, 0.0), tr=None):
    """Landmark detections of robot n with their errors against truth at t+dt.
    offset: (ox, oy) of the rotation centre relative to the Vicon point, in the robot frame
    (the sensor's origin is the Vicon point + R(th) offset)."""
    m = measurements(n)
    L = landmarks()
    tr = tr or Truth(n)
    m = m[m.subject >= 6].copy()
    m = m[m.subject.isin(L.index)]
    x, y, th, ok = tr.at(m.t.values + dt)
    c, s = np.cos(th), np.sin(th)
    x = x + c * offset[0] - s * offset[1]
    y = y + s * offset[0] + c * offset[1]
    lx = L.loc[m.subject, 'x'].values; ly = L.loc[m.subject, 'y'].values
    dx, dy = lx - x, ly - y
    m['rt'] = np.hypot(dx, dy)
    m['bt'] = wrap(np.arctan2(dy, dx) - th)
    m['er'] = m.r - m.rt
    m['eb'] = wrap(m.b - m.bt)
    m['th'] = th; m['x'] = x; m['y'] = y
    m['ok'] = ok
    m['robot'] = n
    return m[m.ok].copy()

def all_detections(**kw):
    return pd.concat([detections(n, **kw) for n in ROBOTS], ignore_index=True)

def robust_inliers(e_r, e_b, rt, k=5.0, bins=8):
    """calibrate's test: |e - median| <= k * 1.4826 MAD per range bin (equal-count bins)."""
    order = np.argsort(rt, kind='stable')
    inl = np.ones(len(rt), bool)
    for chunk in np.array_split(order, bins):
        for e in (e_r, e_b):
            v = e[chunk]; med = np.median(v); mad = 1.4826 * np.median(np.abs(v - med))
            inl[chunk] &= np.abs(v - med) <= k * max(mad, 1e-9)
    return inl
