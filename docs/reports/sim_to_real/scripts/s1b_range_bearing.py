"""1b. The range error's dependence on bearing (found in s1): 2-D table and a model fit."""
import sys, os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import *
di = pd.read_pickle(outpath('det_inliers.pkl'))
di['rbin'] = pd.cut(di.rt, [0, 2, 3, 4, 5, 9])
di['bbin'] = pd.cut(np.degrees(di.bt), [-40, -25, -15, -5, 5, 15, 25, 40])
print("mean range error [cm] by true range (rows) and true bearing (cols)")
print((100 * di.pivot_table(index='rbin', columns='bbin', values='er', aggfunc='mean')).round(1).to_string())
print("relative range error er/r [%]")
di['rel'] = di.er / di.rt
print((100 * di.pivot_table(index='rbin', columns='bbin', values='rel', aggfunc='mean')).round(1).to_string())
print("sd of range error [cm] within cells")
print((100 * di.pivot_table(index='rbin', columns='bbin', values='er', aggfunc='std')).round(1).to_string())
# use measured bearing as the sensor would know it (b), models:
b = di.b.values; r = di.r.values; rt = di.rt.values; e = di.er.values
def fit(cols, name):
    A = np.column_stack(cols); c = np.linalg.lstsq(A, e, rcond=None)[0]; res = e - A @ c
    print(f"{name}: coefs {np.round(c, 4)}, residual sd {100*res.std():.2f} cm (of {100*e.std():.2f}); var explained {1 - res.var()/e.var():.3f}")
    return c, res
fit([np.ones_like(r), r], "a + b r (calibrate)")
fit([np.ones_like(r), r, b**2], "a + b r + c bearing^2")
c, res = fit([np.ones_like(r), r, r*b**2], "a + b r + c r bearing^2")
fit([np.ones_like(r), r, b**2, r*b**2, b**4 * r], "a + b r + c b^2 + d r b^2 + e r b^4")
fit([np.ones_like(r), r, r*b**2, r*b], "a + b r + c r b^2 + d r b (asymmetric)")
# the depth hypothesis: the camera measures the distance along its axis, r cos(bearing)
e_cos = (di.r - di.rt*np.cos(di.bt)).values
A = np.column_stack([np.ones_like(r), rt*np.cos(di.bt.values)]); cc = np.linalg.lstsq(A, di.r.values, rcond=None)[0]
rc = di.r.values - A @ cc
print(f"r_meas = {cc[0]:+.4f} + {cc[1]:.4f} * r_true cos(bearing_true): residual sd {100*rc.std():.2f} cm, var explained {1-rc.var()/e.var():.3f}")
for n in ROBOTS:
    m = (di.robot == n).values; A2 = A[m]; c2 = np.linalg.lstsq(A2, di.r.values[m], rcond=None)[0]; r2 = di.r.values[m] - A2 @ c2
    print(f"  robot {n}: r_meas = {c2[0]:+.4f} + {c2[1]:.4f} r cos b; sd {100*e[m].std():.1f} -> {100*r2.std():.1f} cm")
di["res_cos"] = rc
print("residual (cos model) mean by bearing bin [cm]:", (100*di.groupby("bbin").res_cos.mean()).round(2).to_dict())
print("residual (cos model) sd by range bin [cm]:", (100*di.groupby("rbin").res_cos.std()).round(2).to_dict())
A3 = np.column_stack([np.ones(len(rt)), rt]); print("cos-model residual spread line a + b r [m] (from E|res| sqrt(pi/2)):", np.round(np.linalg.lstsq(A3, np.abs(rc)*np.sqrt(np.pi/2), rcond=None)[0], 4))

# per robot fits of the relative model
print("per robot: e = a + b r + c r bearing^2")
for n in ROBOTS:
    m = di.robot == n
    A = np.c_[np.ones(m.sum()), r[m], r[m]*b[m]**2]; cc = np.linalg.lstsq(A, e[m], rcond=None)[0]
    rr = e[m] - A @ cc
    print(f"  robot {n}: a {cc[0]:+.3f} m, b {cc[1]:+.4f}, c {cc[2]:+.3f} /rad^2; sd {100*e[m].std():.1f} -> {100*rr.std():.1f} cm")
# residual spread after the bearing model vs range (the sensor's own noise)
di['res'] = res
g = di.groupby('rbin').res.std() * 100
print("residual sd by range bin [cm]:", g.round(2).to_dict())
A = np.c_[np.ones(len(r)), rt]; print("residual sd line (|res| LS): ", np.round(np.linalg.lstsq(A, np.abs(res)*np.sqrt(np.pi/2), rcond=None)[0], 4))
di.to_pickle(outpath('det_inliers_b.pkl'))
