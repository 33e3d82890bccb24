"""Identifying a tool from mean readings at poses (tactile.payload.fit), and its removal."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tactile.errors import DataError
from tactile.payload import Tool, compensate, identify, tare_bias, weight
from tactile.payload.fit import MIN_SPREAD, spread

NINE = [
    (0, 0, 0), (90, 0, 0), (-90, 0, 0), (0, 90, 0), (0, -90, 0),
    (180, 0, 0), (45, 45, 0), (-60, 30, 45), (120, -45, 30),
]  # fmt: skip
TOOL = Tool(0.03, [0.02, 0.001, -0.002], [0.1, -0.2, 0.05], [0.001, 0.002, -0.003])


def R_of(rpy):
    angles = np.asarray(rpy, float).reshape(-1, 3)
    return Rotation.from_euler("xyz", angles, degrees=True).as_matrix()


def means(R, tool=TOOL, sd=(0.0,) * 6, seed=0):
    W = weight(R, tool) + tool.bias
    W = W + np.random.default_rng(seed).normal(size=W.shape) * np.asarray(sd)
    return W[:, :3], W[:, 3:]


def test_noise_free_poses_give_the_tool_back_exactly():
    R = R_of(NINE)
    got = identify(R, *means(R), sensor=2, cal_id=77)
    assert got.mass_kg == pytest.approx(0.03, rel=1e-12)
    assert np.allclose(got.com_m, TOOL.com_m, atol=1e-12)
    assert np.allclose(got.bias, TOOL.bias, atol=1e-12)
    assert (got.sensor, got.cal_id, got.poses) == (2, 77, 9)
    assert got.residual_force_N < 1e-12 and got.residual_torque_Nm < 1e-12


def test_errors_are_within_the_standard_errors_it_reports():
    """Over 200 noisy fits, each parameter's error / its standard error has sd ~1."""
    R = R_of(NINE)
    z = []
    for seed in range(200):
        got = identify(R, *means(R, sd=(3e-3,) * 3 + (1e-4,) * 3, seed=seed))
        est = np.r_[got.mass_kg, got.com_m, got.bias]
        se = np.r_[got.mass_kg_se, got.com_m_se, got.bias_force_N_se, got.bias_torque_Nm_se]
        truth = np.r_[TOOL.mass_kg, TOOL.com_m, TOOL.bias]
        z.append((est - truth) / se)
    sd = np.std(z, axis=0)
    assert np.all((sd > 0.7) & (sd < 1.4)), sd
    assert got.residual_force_N == pytest.approx(3e-3, rel=0.4)


@pytest.mark.parametrize("mass", [0.01, 0.03, 0.1])
def test_nine_poses_leave_under_10_mN_rms_over_a_sweep(mass):
    """The bench's criterion at the thesis's sensor noise averaged over a 0.6 s hold at
    500 Hz (3.2 mN per hold mean): the weight left after compensation over a sweep."""
    tool = Tool(mass, [0.02, 0.0, 0.003])
    R = R_of(NINE)
    got = identify(R, *means(R, tool, sd=(3.2e-3,) * 3 + (1.6e-4,) * 3, seed=1))
    sweep = R_of(np.random.default_rng(5).uniform(-180, 180, (400, 3)))
    left = weight(sweep, tool) - weight(sweep, got)
    assert np.sqrt(np.mean(np.sum(left[:, :3] ** 2, axis=1))) < 0.010


def test_turning_about_the_gravity_axis_identifies_nothing():
    R = R_of([(0, 0, a) for a in (0, 60, 120, 180, 240)])
    with pytest.raises(DataError, match="same way in the sensor frame at every pose"):
        identify(R, *means(R))


def test_a_vertical_fingertip_turned_about_its_own_axis_identifies_nothing():
    """The fingertip's axis is the sensor's +x; pointing down (sensor +x = world -z) and
    turned about it, gravity stays along +x in the sensor frame."""
    down = Rotation.from_euler("y", 90, degrees=True)  # sensor +x -> world -z
    turns = Rotation.from_euler("x", [[0], [45], [90], [135], [180], [270]], degrees=True)
    R = (down * turns).as_matrix()
    assert np.allclose(R[:, :, 0], [0, 0, -1])
    with pytest.raises(DataError, match="same way") as err:
        identify(R, *means(R))
    assert "\n" not in str(err.value)


def test_two_orientations_leave_the_centre_of_mass_along_their_line():
    R = R_of([(0, 0, 0), (90, 0, 0), (0, 0, 0), (90, 0, 0)])
    with pytest.raises(DataError, match=r"centre of mass along \(\+0.00, \+0.71, -0.71\)"):
        identify(R, *means(R))


def test_turning_about_one_tilted_axis_does_determine_the_tool():
    """Gravity then runs round a cone in the sensor frame: determined, with errors ~1/tilt."""
    R = (Rotation.from_euler("y", 60, degrees=True) * Rotation.from_euler(
        "x", [[0], [90], [180], [270]], degrees=True)).as_matrix()  # fmt: skip
    s, _ = spread(np.einsum("nji,j->ni", R, [0, 0, -9.81]))
    assert s[1] > MIN_SPREAD
    got = identify(R, *means(R))
    assert np.allclose(got.com_m, TOOL.com_m, atol=1e-9)


def test_fewer_than_three_poses_and_a_mass_below_its_noise_are_refused():
    R = R_of(NINE[:2])
    with pytest.raises(DataError, match="at least 3 needed"):
        identify(R, *means(R))
    R = R_of(NINE)
    light = Tool(1e-6, [0.02, 0, 0])
    with pytest.raises(DataError, match="not above its noise"):
        identify(R, *means(R, light, sd=(3e-3,) * 3 + (1e-4,) * 3))


def test_gravity_the_wrong_way_is_a_negative_mass_and_refused():
    R = R_of(NINE)
    with pytest.raises(DataError, match="z must point up"):
        identify(R, *means(R), g=(0, 0, 9.81))


def test_compensate_and_tare_bias_at_any_pose():
    R = R_of([(30, -70, 10)])[0]
    reading = weight(R, TOOL) + TOOL.bias
    assert np.allclose(tare_bias(reading, R, TOOL), TOOL.bias)
    assert np.allclose(compensate(reading, R, TOOL), 0.0)
    press = np.array([0.0, 0.0, 5.0, 0.0, 0.1, 0.0])
    assert np.allclose(compensate(reading + press, R, TOOL), press)
    # what the board's TARE takes (the whole reading) holds at that pose only
    other = R_of([(0, 0, 0)])[0]
    board = weight(other, TOOL) + TOOL.bias - reading
    assert np.linalg.norm(board[:3]) > 0.2
    assert np.allclose(compensate(weight(other, TOOL) + TOOL.bias, other, TOOL), 0.0)
