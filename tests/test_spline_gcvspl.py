"""``spline-smooth --lambda gcv`` against Woltring's GCVSPL on its own published test data (issue 36, item 5).

GCVSPL (H.J. Woltring 1986, "A FORTRAN package for generalized, cross-validatory spline smoothing and
differentiation", Adv. Eng. Software 8(2):104-113) ships a test programme (GCVTST/GCV.FOR) run on the
falling golf ball of C.L. Vaughan (1982), Int. J. Bio-Medical Computing 13:375-382, Table 1: 50 heights [m]
sampled every 9.85 ms.  The reference below is GCVSPL.FOR (1986-05-12) itself, compiled with gfortran and
run as its test programme does for a cubic spline (M = 2) chosen by generalized cross-validation (MD = 2),
unit weights: the smoothing parameter p = WK(4) and the spline's values and first derivatives at the knots
(SPLDER).  GCVSPL's criterion sum w (y - s)^2 + p int s''^2 is the one of eq 5 with alpha = p.

The robust weights are exactly 1 on clean data (every fix consistent with its neighbours), so the
default command reproduces GCVSPL, not only ``--no-robust``.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_cli, session_bytes

from sportfusion.core import io as sfio
from sportfusion.core.schema import floats
from sportfusion.estimators.spline import smoothing_spline

DT = 9.85e-3  # [s]
Y = [1.770, 1.757, 1.748, 1.740, 1.726, 1.715, 1.698, 1.683, 1.667, 1.651, 1.632, 1.612, 1.593, 1.572, 1.551,
     1.530, 1.507, 1.483, 1.445, 1.428, 1.401, 1.371, 1.343, 1.311, 1.279, 1.245, 1.212, 1.175, 1.143, 1.105,
     1.063, 1.029, 0.991, 0.953, 0.910, 0.869, 0.823, 0.779, 0.732, 0.691, 0.644, 0.595, 0.548, 0.501, 0.447,
     0.395, 0.350, 0.294, 0.243, 0.185]  # fmt: skip
#: GCVSPL's smoothing parameter p (WK(4)), which is eq 5's alpha (unit weights, t in s)
P_GCVSPL = 5.4781998017943762e-06
#: GCVSPL's spline at the knots [m] (SPLDER, IDER = 0)
S_GCVSPL = [1.7699333403, 1.7594000587, 1.7488086241, 1.7377982462, 1.7259083261, 1.7129134832, 1.6987236801,
            1.6834731658, 1.6672589334, 1.6500943772, 1.6319753515, 1.6129962225, 1.5932515889, 1.5727135904,
            1.5512753943, 1.5287318551, 1.5048619227, 1.4796461899, 1.4534482907, 1.4268384381, 1.3995355934,
            1.3711907512, 1.3416534427, 1.3108327437, 1.2787936513, 1.2456657653, 1.2115881896, 1.1766405726,
            1.1408833997, 1.1042598710, 1.0669331670, 1.0290997281, 0.9905171877, 0.9508312615, 0.9098039726,
            0.8674693059, 0.8239916049, 0.7796901017, 0.7347931446, 0.6893387820, 0.6430684545, 0.5958626766,
            0.5477335188, 0.4986275553, 0.4485662483, 0.3978091846, 0.3464210981, 0.2941985326, 0.2412668087,
            0.1878826068]  # fmt: skip
#: GCVSPL's first derivative at the knots [m/s] (SPLDER, IDER = 1)
DS_GCVSPL = [-1.0695655, -1.0689752, -1.0884576, -1.1564267, -1.2605458, -1.3805059, -1.4970183, -1.5980149,
             -1.6940938, -1.7917383, -1.8852216, -1.9663058, -2.0435946, -2.1281377, -2.2284822, -2.3533858,
             -2.4940573, -2.6203337, -2.6835823, -2.7289165, -2.8208627, -2.9361670, -3.0635508, -3.1927792,
             -3.3104467, -3.4132449, -3.5052422, -3.5886875, -3.6744617, -3.7583495, -3.8150537, -3.8728497,
             -3.9674499, -4.0954622, -4.2334062, -4.3603410, -4.4609761, -4.5305375, -4.5839174, -4.6519611,
             -4.7446920, -4.8391506, -4.9347268, -5.0367002, -5.1217022, -5.1825938, -5.2581207, -5.3414670,
             -5.4026983, -5.4282247]  # fmt: skip


def test_library_gcv_is_gcvspl():
    t = DT * np.arange(len(Y))
    fit = smoothing_spline(t, np.array(Y), None, None)
    # the GCV minimum is flat: GCVSPL's golden section (TOL 1e-6) and our Brent search (1e-4 in log10 p)
    # stop within 1e-4 of each other in p, which moves the spline by far less than 1e-4 m
    assert fit.penalty[0] == pytest.approx(P_GCVSPL, rel=1e-3)
    val, d1, _ = fit.spline.evaluate(t)
    np.testing.assert_allclose(val[:, 0], S_GCVSPL, atol=1e-6)  # [m]; measured 1.4e-8
    np.testing.assert_allclose(d1[:, 0], DS_GCVSPL, atol=1e-4)  # [m/s]; measured 1.1e-6


@pytest.mark.parametrize("axis", ["gnss_x", "gnss_z"])
def test_command_with_default_settings_is_gcvspl(axis):
    n = len(Y)
    cols = {a: np.zeros(n) for a in ("gnss_x", "gnss_y", "gnss_z")}
    cols[axis] = np.array(Y)
    data = session_bytes({"t": DT * np.arange(n), **cols}, n=n)
    for extra in ([], ["--no-robust"]):
        res = run_cli(["spline-smooth", "--lambda", "gcv", *extra], stdin=data)
        assert res.returncode == 0, res.stderr.decode()
        out = sfio.table_from_bytes(res.stdout)
        a = axis[-1]
        np.testing.assert_allclose(floats(out, a), S_GCVSPL, atol=1e-4)  # the tolerance [m]
        np.testing.assert_allclose(floats(out, a), S_GCVSPL, atol=1e-6)  # what it is (1.4e-8 m)
        np.testing.assert_allclose(floats(out, f"v{a}"), DS_GCVSPL, atol=1e-4)
        if not extra:
            assert (floats(out, "gnss_weight") == 1.0).all()  # clean data: every weight exactly 1
