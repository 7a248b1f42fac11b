"""The EPD coat of runtimes/testing/out_of_family.py (the file of `twoscale fit --compare`'s epd_lambert): its D is
normalised, its Lambda spline agrees with reference.smith_lambda, and at p = 1 its file is the Beckmann one. No fit,
no tables.

    pytest pipeline/fit/tests/test_epd_file.py     (about 3 s)"""
import math

import merl
import numpy as np
import out_of_family
import pytest
import reference
from scipy.integrate import quad


@pytest.mark.parametrize("beta, p", [(0.1, 0.6), (0.3, 0.3), (0.05, 2.0)])
def test_the_epd_is_normalised(beta, p):
    # int D cos theta_h dh = 2 pi int D(theta) cos theta sin theta dtheta, in x = ln tan theta (dtheta = t dx / (1 + t^2),
    # cos theta sin theta = t / (1 + t^2)); D is below exp(-700) of its peak beyond t = beta 700^(1/2p)
    def f(x):
        t = math.exp(x)
        return 2.0 * math.pi * out_of_family.ndf("epd", (beta, p), 1.0 / math.sqrt(1.0 + t * t)) * t * t / (1.0 + t * t) ** 2

    hi = math.log(beta * 700.0 ** (0.5 / p))
    total, _ = quad(f, math.log(beta) - 40.0, hi, points=[math.log(beta)], epsabs=0.0, epsrel=1e-10, limit=400)
    print(f"beta {beta}, p {p}: int D cos theta_h dh - 1 = {total - 1.0:.1e}")
    assert abs(total - 1.0) < 1e-10


def test_the_epd_lambda_spline_is_reference_smith_lambda():
    # at the material's p, at the spline's worst points (midway between its nodes) over the a = beta tan theta the
    # file reaches (beta 0.1, cos theta >= 1e-6), and at random ones
    p = out_of_family.MATERIALS["epd_conductor_lambert"][1][1]
    x = np.linspace(-math.log(50.0) / (2.0 * p), math.log(1e5), 3000)  # merl.smith_lambda_at's default nodes
    a = np.exp(np.concatenate([0.5 * (x[1:] + x[:-1])[::10], np.random.default_rng(5).uniform(x[0], x[-1], 200)]))
    want = np.array([reference.smith_lambda(p, v) for v in a])
    worst = np.max(np.abs(out_of_family.epd_lambda(p)(a) / want - 1.0))
    print(f"p {p}: the spline's largest relative error {worst:.2e}")
    assert worst < 1e-10


def test_the_epd_file_at_p_1_is_the_beckmann_one():
    # the same metal, alpha = beta; without the base, rho is the coat alone, so relative errors are G2's and D's
    _, (beta, _), under, _, _ = out_of_family.MATERIALS["epd_conductor_lambert"]
    epd = out_of_family.rho("epd", (beta, 1.0), under, (0.0, 0.0, 0.0))
    beckmann = out_of_family.rho("beckmann", (beta,), under, (0.0, 0.0, 0.0))
    valid = merl.directions()[2]
    e, b = epd[:, valid], beckmann[:, valid]
    assert np.all(np.isfinite(e)) and np.all(np.isfinite(b))
    rel = np.abs(e - b) / np.maximum(b, np.finfo(float).tiny)  # 0 where both underflow to 0
    print(f"largest relative difference {rel.max():.2e} over {e.size} samples")
    assert rel.max() < 1e-10
