"""The shaft angle's advance is the delay of the transducer filter the diagnosis compares through.

The measured speed lags the shaft's by the transducer's delay, so the angle integrated from it
lags by that delay times the speed; the replay advances it by the delay of ``first_order`` as
sampled (``transducer_delay``), which is 1/(2 pi f_c) - dt/2 where the samples are dense and
nearly 0 where they are sparse. The continuous 1/(2 pi f_c) it used before turned a roller-pass
ripple's phase where the sample interval is comparable to the transducer's time constant
(seed 1 #5 of benchmarks/fuzz_diagnosis.py: 200 Hz sampling, an 80 Hz transducer)."""
import math

import numpy as np
import pytest

from cyclo_fmu.diagnosis.replay import first_order, transducer_delay


@pytest.mark.parametrize("fs, fc", [(200.0, 80.0), (200.0, 1000.0), (1000.0, 1000.0),
                                    (5000.0, 1000.0), (50000.0, 200.0)])
def test_delay_is_the_lag_of_a_ramp(fs, fc):
    """A ramp through first_order comes out transducer_delay late (closed form of the
    recursion's steady state), whatever the ratio of sample interval to time constant."""
    dt = 1.0 / fs
    t = np.arange(4000) * dt
    y = first_order(t.copy(), dt, fc)
    lag = float(np.median((t - y)[2000:]))
    assert lag == pytest.approx(transducer_delay(fc, dt), rel=1e-6, abs=1e-15)


def test_dense_samples_approach_the_continuous_delay():
    """Where dt << 1/(2 pi f_c) the delay is the continuous filter's less half a sample."""
    fc, dt = 200.0, 2e-5
    assert transducer_delay(fc, dt) == pytest.approx(1 / (2 * math.pi * fc) - dt / 2, rel=1e-4)
    assert transducer_delay(0.0, dt) == 0.0


@pytest.mark.slow
def test_ripple_phase_recovered_through_a_slow_transducer():
    """A roller-pass and 1x ripple recorded at 200 Hz through an 80 Hz transducer (the
    synthesiser's first-order filter on speed and torque), diagnosed with that bandwidth:
    the fitted sine and cosine parts are the hidden ones within 3 % of the amplitude (the
    continuous advance turned the roller-pass phase by 0.9 rad and added a load-scaled part
    the recording does not have), and nothing is left unexplained."""
    from types import SimpleNamespace
    from cyclo_fmu.diagnosis import Diagnoser
    from cyclo_fmu.synth import SynthSettings, synthesize
    hidden = {"A1_sin": 0.009, "A1_cos": 0.0045, "Az_sin": 0.006, "Az_cos": 0.0}
    st = SynthSettings(sample_rate=200.0, torque_noise=0.003, bandwidth=80.0, speed_noise=0.0,
                       speed_resolution=0.0)
    r = synthesize({"mesh_ripple": (hidden, 0.0)}, 7, "S2", "small", settings=st)
    rec = SimpleNamespace(time=r["time_s"], speed_in=r["speed_in_rpm"] * np.pi / 30,
                          torque_in=r["torque_in_Nm"], speed_out=r["speed_out_rpm"] * np.pi / 30,
                          torque_out=r["torque_out_Nm"], temperature=None)
    d = Diagnoser(mode="S2", bandwidth=80.0).fit(rec).diagnosis_
    rip = next(e for e in d.effects if e["id"] == "mesh_ripple")
    got = {k: v["value"] for k, v in rip["parameters"].items()}
    amp = math.hypot(hidden["Az_sin"], hidden["Az_cos"])
    for k, v in hidden.items():
        assert abs(got[k] - v) < 0.03 * amp, (k, got[k], v)
    assert got["load_law"] == 0.0
    assert not d.unexplained["present"], d.unexplained["statement"]
