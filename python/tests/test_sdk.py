"""The Python SDK's filter maths (locsim.models, locsim.particles): Jacobians against finite
differences, the random models and resamplers by their statistics. Agreement with the C++ SDK's
numbers is tests/python_sdk_test.cpp's."""
import math

import numpy as np
import pytest

import locsim


def continuous(f, x0):
    """f with its heading (last component) unwrapped about f(x0)'s, so that finite differences
    across +-pi stay small."""
    reference = f(np.asarray(x0, dtype=float))

    def g(x):
        out = np.array(f(x), dtype=float)
        out[-1] = reference[-1] + locsim.wrap_angle(out[-1] - reference[-1])
        return out
    return g


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (1.0, -2.0, 0.7), (-3.0, 4.0, -2.9)])
@pytest.mark.parametrize("travel", [(0.1, 0.12), (-0.05, 0.05), (0.2, 0.2)])
def test_diff_drive_jacobians_match_finite_differences(pose, travel):
    b = 0.35
    _, F, G = locsim.diff_drive_motion(np.array(pose), *travel, b, jacobians=True)
    F_numeric = locsim.numeric_jacobian(continuous(lambda x: locsim.diff_drive_motion(x, *travel, b), pose), pose)
    G_numeric = locsim.numeric_jacobian(
        continuous(lambda u: locsim.diff_drive_motion(np.array(pose), u[0], u[1], b), travel), travel)
    np.testing.assert_allclose(F, F_numeric, atol=1e-8)
    np.testing.assert_allclose(G, G_numeric, atol=1e-8)


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (1.0, -2.0, 0.7), (2.5, 0.5, 3.0)])
def test_range_bearing_jacobian_matches_finite_differences(pose):
    landmark = (2.0, 1.0)
    _, H = locsim.range_bearing(np.array(pose), landmark, jacobian=True)
    h = continuous(lambda x: locsim.range_bearing(x, landmark), pose)
    np.testing.assert_allclose(H, locsim.numeric_jacobian(h, pose), atol=1e-7)


def test_sample_motion_spreads_as_motion_spread_says():
    rng = np.random.default_rng(5)
    delta = locsim.decompose((0.0, 0.0, 0.0), (1.0, 0.3, 0.5))
    noise = locsim.OdometryNoise(alpha1=0.05, alpha2=0.02, alpha3=0.05, alpha4=0.1)
    spread = locsim.motion_spread(delta, noise)
    x = locsim.sample_motion(np.zeros((40000, 3)), delta, rng, noise)
    # Along the motion the distance spreads by the translation's deviation; its mean is the move.
    distance = np.hypot(x[:, 0], x[:, 1])
    assert distance.mean() == pytest.approx(delta[1], abs=3 * spread[1] / 200)
    assert distance.std() == pytest.approx(spread[1], rel=0.03)
    heading = x[:, 2]  # rot1 + rot2, each with its own deviation
    assert heading.std() == pytest.approx(math.hypot(spread[0], spread[2]), rel=0.03)
    assert np.all(np.abs(heading) <= math.pi)


def test_sample_wheel_motion_is_centred_on_the_noiseless_move():
    rng = np.random.default_rng(6)
    x = locsim.sample_wheel_motion(np.zeros((40000, 3)), 0.2, 0.25, 0.35, rng, k_left=0.05, k_right=0.05)
    noiseless = locsim.diff_drive_motion(np.zeros(3), 0.2, 0.25, 0.35)
    np.testing.assert_allclose(x.mean(axis=0), noiseless, atol=2e-3)
    assert x[:, 0].std() == pytest.approx(0.05 * math.sqrt(0.225) / math.sqrt(2), rel=0.05)


@pytest.mark.parametrize("resample", [locsim.low_variance_resample, locsim.roulette_resample])
def test_resamplers_draw_by_weight_in_ascending_order(resample):
    rng = np.random.default_rng(7)
    w = locsim.normalize(rng.random(50) ** 3)
    n_draws, counts = 0, np.zeros(50)
    for _ in range(200):
        keep = resample(w, rng)
        assert len(keep) == 50 and np.all(np.diff(keep) >= 0) and keep.min() >= 0 and keep.max() < 50
        counts += np.bincount(keep, minlength=50)
        n_draws += 50
        if resample is locsim.low_variance_resample:  # systematic: within one of n w_i each time
            assert np.all(np.abs(np.bincount(keep, minlength=50) - 50 * w) < 1.0 + 1e-9)
    np.testing.assert_allclose(counts / n_draws, w, atol=0.01)


def test_weights_from_log_survive_underflow_and_degenerate_input():
    w = locsim.weights_from_log(np.array([-2000.0, -2001.0, -1e308]))
    assert w.sum() == pytest.approx(1.0) and w[0] == pytest.approx(1 / (1 + math.exp(-1)))
    np.testing.assert_array_equal(locsim.weights_from_log(np.full(4, -np.inf)), np.full(4, 0.25))
    np.testing.assert_array_equal(locsim.normalize(np.zeros(3)), np.full(3, 1 / 3))
    assert locsim.effective_sample_size(np.full(8, 1 / 8)) == pytest.approx(8.0)


def test_mean_and_covariance_take_the_circular_mean_across_pi():
    x = np.array([[0.0, 0.0, math.pi - 0.1], [2.0, 0.0, -math.pi + 0.1]])
    mean, covariance = locsim.mean_and_covariance(x, np.array([0.5, 0.5]))
    assert abs(locsim.wrap_angle(mean[2] - math.pi)) < 1e-12
    np.testing.assert_allclose(np.diag(covariance), [1.0, 0.0, 0.01], atol=1e-12)


def test_free_space_poses_lie_in_free_cells():
    grid = np.full((20, 30), 100, dtype=np.uint8)
    grid[5:8, 10:25] = 0
    init = locsim.Init(params={}, seed=1, rng=None, initial_pose_known=False, initial_pose=np.zeros(3),
                       initial_covariance=np.eye(3), landmarks=np.zeros((0, 2)), landmark_ids=np.zeros(0),
                       landmark_colors=[], landmark_radii=np.zeros(0), beacons=np.zeros((0, 3)),
                       beacon_ids=np.zeros(0), grid=grid, grid_origin=(-1.0, 2.0), grid_resolution_m=0.1,
                       wheel_base_m=0.3, wheel_radius_m=0.05, footprint_radius_m=0.2)
    x = locsim.free_space_poses(init, 5000, np.random.default_rng(8))
    cols = np.floor((x[:, 0] + 1.0) / 0.1).astype(int)
    rows = np.floor((x[:, 1] - 2.0) / 0.1).astype(int)
    assert np.all(grid[rows, cols] == 0)
    assert x[:, 2].min() < -3.0 and x[:, 2].max() > 3.0


def test_lost_watch_widens_while_more_is_rejected_than_accepted_as_the_cpp_sdks_does():
    """The sequence and numbers of tests/plugin_test.cpp's LostWatch test."""
    watch = locsim.LostWatch(3, 0.5, 0.2, 1.0, 0.3)
    P = np.eye(5) * 0.01
    for i in range(20):  # outliers among accepted detections: the count returns to 0
        assert not watch.rejected(0.1 * i, P)
        watch.accepted()
        watch.accepted()
    assert not watch.rejected(3.0, P)
    assert not watch.rejected(3.1, P)
    watch.accepted()
    assert not watch.rejected(3.2, P)
    assert np.array_equal(P, np.eye(5) * 0.01) and not watch.lost
    assert watch.rejected(3.4, P) and watch.lost and watch.times_lost == 1
    assert P[0, 0] == pytest.approx(0.01 + 0.25 * 0.4, abs=1e-12)
    assert P[2, 2] == pytest.approx(0.01 + 0.04 * 0.4, abs=1e-12)
    assert P[3, 3] == 0.01 and P[0, 1] == 0.0
    assert watch.rejected(3.5, P)
    watch.accepted()
    assert watch.lost
    assert watch.rejected(4.5, P)
    assert P[0, 0] == pytest.approx(0.11 + 0.25 * 0.1 + 0.25, abs=1e-12)
    assert watch.rejected(100.0, P)
    assert P[0, 0] == pytest.approx(1.0, abs=1e-12) and P[2, 2] == pytest.approx(0.09, abs=1e-12)
    P[2, 2] = 0.5
    assert watch.rejected(101.0, P) and P[2, 2] == 0.5 and watch.times_lost == 1
    for _ in range(5):
        watch.accepted()
    assert not watch.lost
    assert not watch.rejected(102.0, P)
    assert watch.rejected(103.0, P) and watch.times_lost == 2
    off = locsim.LostWatch(0)
    assert not any(off.rejected(float(i), P) for i in range(100)) and not off.lost
    # From a filter's parameters, the heading in degrees.
    defaults = {p.name: p.default for p in locsim.lost_params()}
    from_params = locsim.LostWatch.from_params(defaults)
    assert from_params.after_rejections == 12 and from_params.growth_rad == pytest.approx(math.radians(20.0))
