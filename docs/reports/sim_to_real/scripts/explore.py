import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
print(barcodes()); print(landmarks())
for n in ROBOTS:
    g = truth(n); o = odometry(n); m = measurements(n)
    dg = np.diff(g.t.values); do = np.diff(o.t.values)
    print(f"R{n}: truth {len(g)} {g.t.min():.2f}-{g.t.max():.2f} dt med {np.median(dg):.4f} max {dg.max():.2f} gaps>0.1: {(dg>0.1).sum()} dup {(dg==0).sum()}")
    print(f"    odo {len(o)} {o.t.min():.2f}-{o.t.max():.2f} dt med {np.median(do):.4f} max {do.max():.3f}; v range {o.v.min()} {o.v.max()} w {o.w.min()} {o.w.max()}")
    print(f"    meas {len(m)} subjects: {m.subject.value_counts().sort_index().to_dict()}")
    print(f"    bearing max abs {m.b.abs().max():.3f}  range {m.r.min():.2f}-{m.r.max():.2f}; frames {m.t.nunique()}")
