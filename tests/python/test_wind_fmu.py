"""The packaged wind FMU (Wind.fmu) under fmpy, an FMI master written independently of this project.

fmpy's validation is clean; simulate_fmu runs a 2 h record whose gust variance lies inside the
interval that the record length allows around Davenport's 6 kappa v_m^2 (the interval computed
here from Eq. 2, not picked); the same seed gives the same record and another seed another
record; an FMU state replays the same gusts; paper mode at a speed without a paper filter is
refused with a message naming H3 and H10; and the steady torque equals Eq. 3 computed by hand
from the coefficient table the FMU ships. The Rust tests in tests/rust/wind_fmu.rs check the
same FMU through the C ABI in more depth (spectra, step sizes, many seeds, paper mode).
"""

import math
import zipfile
from statistics import NormalDist

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from conftest import FMU_DIRECTORY, PACKAGE_HINT
from fmu_slave import FMI2_ERROR, Packaged

# Values of the `spectrum` enumeration in the model description.
PAPER = 2
OFF = 3
# The FMU's defaults for the site and the dish.
HEIGHT = 10.0
ROUGHNESS = 0.4
DENSITY = 1.075
DIAMETER = 13.5


def wind_path():
    path = FMU_DIRECTORY / "Wind.fmu"
    if not path.is_file():
        pytest.fail(f"{path} is missing: {PACKAGE_HINT}")
    return path


@pytest.fixture(scope="module")
def packaged():
    p = Packaged(wind_path())
    yield p
    p.close()


def kappa(z=HEIGHT, z0=ROUGHNESS):
    return 1.0 / (2.5 * math.log(z / z0)) ** 2


def eq2_per_hz(n, v_mean, k):
    """Eq. 2 as a one-sided spectrum per hertz at n = omega / 2 pi: x = beta omega = 1200 n / v_m."""
    x = 1200.0 * n / v_mean
    return 4800.0 * v_mean * k * x / (1.0 + x * x) ** (4.0 / 3.0)


def sample_variance_interval(v_mean, step, samples, confidence):
    """The interval that the mean square of `samples` gust values `step` apart falls in with
    probability `confidence`, as factors on 6 kappa v_m^2.

    Var(s^2) = (2 / N) sum_m (1 - |m| / N) R(m h)^2 for a Gaussian process, with the
    autocovariance R(tau) = int_0^inf S(n) cos(2 pi n tau) dn of Eq. 2 evaluated by an inverse
    FFT on a period of 16 record lengths (so that the wrap-around is negligible) and R(0) set to
    the exact 6 kappa v_m^2 (the FFT grid stops at the sampling's Nyquist frequency). Then
    s^2 / sigma^2 ~ chi2_nu / nu with nu = 2 sigma^4 / Var(s^2), whose quantiles come from the
    Wilson-Hilferty approximation (good to 1e-3 at the hundreds of degrees of freedom here)."""
    k = kappa()
    variance = 6.0 * k * v_mean**2
    period = 16.0 * samples * step
    bins = int(round(period / step))
    n = np.arange(bins // 2 + 1) / period
    spectrum = eq2_per_hz(n, v_mean, k)
    # irfft returns (1/bins) sum over the two-sided spectrum; one-sided S over [0, Nyquist]
    # with spacing 1/period: R(m h) = sum_k S(n_k) cos(2 pi n_k m h) / period.
    autocovariance = np.fft.irfft(spectrum, bins) * bins / (2.0 * period)
    autocovariance[0] = variance
    lags = np.arange(samples)
    weights = np.where(lags == 0, 1.0, 2.0) * (1.0 - lags / samples)
    variance_of_s2 = 2.0 / samples * np.sum(weights * autocovariance[:samples] ** 2)
    dof = 2.0 * variance**2 / variance_of_s2
    z = NormalDist().inv_cdf(0.5 + 0.5 * confidence)
    a = 2.0 / (9.0 * dof)
    low = (1.0 - a - z * math.sqrt(a)) ** 3
    high = (1.0 - a + z * math.sqrt(a)) ** 3
    return low, high, math.sqrt(variance_of_s2) / variance


def shipped_coefficients():
    """The coefficient table in the FMU's resources, as {(yaw, elevation): (tau_az, tau_el)}."""
    with zipfile.ZipFile(wind_path()) as archive:
        text = archive.read("resources/wind_coefficients.csv").decode()
    table = {}
    for line in text.splitlines():
        if not line.strip() or line.startswith("#") or line.startswith("yaw_deg"):
            continue
        yaw, elevation, tau_az, tau_el = (float(c) for c in line.split(","))
        table[(yaw, elevation)] = (tau_az, tau_el)
    return table


def test_fmpy_validate_reports_no_problem_for_the_wind_fmu():
    assert validate_fmu(str(wind_path())) == []


def test_simulate_fmu_gives_a_two_hour_gust_with_six_kappa_v_squared_within_its_interval():
    v_mean, step = 3.0, 0.1
    result = simulate_fmu(
        str(wind_path()),
        stop_time=7200.0,
        step_size=step,
        output_interval=step,
        start_values={"wind.mean_speed": v_mean, "seed": 2024},
        output=["wind.gust", "wind.speed", "wind.sigma"],
    )
    gust = result["wind.gust"][1:]
    assert len(gust) == 72000
    assert np.array_equal(result["wind.speed"], v_mean + result["wind.gust"]), "wind.speed is not v_m + v_t"
    target = 6.0 * kappa() * v_mean**2
    assert math.isclose(result["wind.sigma"][-1] ** 2, target, rel_tol=1e-9)
    low, high, relative_std = sample_variance_interval(v_mean, step, len(gust), 0.99)
    ratio = float(np.mean(gust**2)) / target
    # PHYSICS-NOTES point 8: about 4 % scatter of the sample std (8 % of the variance) at 3 m/s.
    assert 0.07 < relative_std < 0.095, f"computed scatter of the variance {relative_std}"
    assert low < ratio < high, f"sample variance / 6 kappa v^2 = {ratio:.4f} outside {low:.4f}-{high:.4f}"


def test_the_same_seed_gives_the_same_record_and_another_seed_another():
    def run(seed):
        return simulate_fmu(str(wind_path()), stop_time=600.0, step_size=0.1, output_interval=0.1, start_values={"wind.mean_speed": 9.5, "seed": seed}, output=["wind.gust"])["wind.gust"]

    first, again, other = run(7), run(7), run(8)
    assert np.array_equal(first.view(np.uint64), again.view(np.uint64)), "seed 7 gave two different records"
    assert np.count_nonzero(first == other) == 0, "seeds 7 and 8 share gust values"


def test_a_restored_state_replays_the_same_gusts(packaged):
    fmu, _ = packaged.slave()
    fmu.setupExperiment(startTime=0.0)
    fmu.setReal([packaged.vr["wind.mean_speed"]], [9.5])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    gust = [packaged.vr["wind.gust"]]

    def run(start, steps, h=0.05):
        values = []
        for k in range(steps):
            fmu.doStep(start + k * h, h)
            values.append(fmu.getReal(gust)[0])
        return np.array(values)

    run(0.0, 200)
    state = fmu.getFMUstate()
    first = run(10.0, 1000)
    fmu.setFMUstate(state)
    assert np.array_equal(first, run(10.0, 1000))
    assert np.ptp(first) > 0.0, "the gust did not move"
    fmu.freeFMUstate(state)
    fmu.freeInstance()


def test_paper_mode_at_5_m_per_s_is_refused_naming_h3_and_h10(packaged):
    fmu, logger = packaged.slave()
    fmu.setupExperiment(startTime=0.0)
    fmu.setInteger([packaged.vr["spectrum"]], [PAPER])
    fmu.setReal([packaged.vr["wind.mean_speed"]], [5.0])
    fmu.enterInitializationMode()
    with pytest.raises(FMICallException) as caught:
        fmu.exitInitializationMode()
    assert caught.value.status == FMI2_ERROR
    messages = [m[2] for m in logger.errors()]
    assert any("H3" in m and "H10" in m for m in messages), messages
    fmu.freeInstance()
    # The speeds the paper's filters exist for are accepted.
    for v_mean in (3.0, 9.5):
        result = simulate_fmu(str(wind_path()), stop_time=10.0, step_size=0.1, start_values={"spectrum": PAPER, "wind.mean_speed": v_mean}, output=["wind.gust"])
        assert np.ptp(result["wind.gust"]) > 0.0


@pytest.mark.parametrize("height, roughness", [(15.0, ROUGHNESS), (HEIGHT, 0.026)])
def test_paper_mode_at_another_site_is_refused_naming_z_and_z0(packaged, height, roughness):
    # H3 and H10 are the paper's fits for z = 10 m and z0 = 0.4 m: moving either alone, at a
    # speed the paper has a filter for, must fail initialisation with a message naming both.
    fmu, logger = packaged.slave()
    fmu.setupExperiment(startTime=0.0)
    fmu.setInteger([packaged.vr["spectrum"]], [PAPER])
    names = ["wind.mean_speed", "wind.reference_height", "wind.roughness_length"]
    fmu.setReal([packaged.vr[n] for n in names], [3.0, height, roughness])
    fmu.enterInitializationMode()
    with pytest.raises(FMICallException) as caught:
        fmu.exitInitializationMode()
    assert caught.value.status == FMI2_ERROR
    messages = [m[2] for m in logger.errors()]
    expected = ("z = 10 m", "z0 = 0.4 m", f"got z = {height:g} m, z0 = {roughness:g} m")
    assert any(all(e in m for e in expected) for m in messages), messages
    fmu.freeInstance()


def test_steady_torque_equals_eq3_computed_by_hand():
    # Wind from 10 deg, antenna at azimuth 235 deg: yaw = 10 - 235 = -225, wrapped to 135 deg (a
    # back-quartering wind), at 30 deg elevation, a table node where the spline equals the table.
    v_mean, direction, azimuth, elevation = 9.8, 10.0, 235.0, 30.0
    result = simulate_fmu(
        str(wind_path()),
        stop_time=5.0,
        step_size=0.1,
        output_interval=0.1,
        start_values={"spectrum": OFF, "wind.mean_speed": v_mean, "wind.direction": direction, "antenna.azimuth": azimuth, "antenna.elevation": elevation},
        output=["torque.azimuth", "torque.elevation", "wind.yaw"],
    )
    tau_az, tau_el = shipped_coefficients()[(135.0, elevation)]
    k = 0.5 * DENSITY * (math.pi * DIAMETER**2 / 4.0) * DIAMETER
    expected_az, expected_el = tau_az * k * v_mean**2, tau_el * k * v_mean**2
    assert np.all(result["wind.yaw"] == 135.0)
    assert np.allclose(result["torque.azimuth"], expected_az, rtol=1e-9, atol=0.0), (result["torque.azimuth"][0], expected_az)
    assert np.allclose(result["torque.elevation"], expected_el, rtol=1e-9, atol=0.0), (result["torque.elevation"][0], expected_el)
    # The conventions: the dish weather-vanes to point downwind (towards lower azimuth) and a
    # wind from behind pushes it down.
    assert expected_az < 0.0 and expected_el < 0.0
