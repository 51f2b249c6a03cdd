import numpy as np
import pytest

# Tolerances per dtype (kornia style) instead of magic atol scattered through tests.
TOL = {np.float32: dict(rtol=1e-5, atol=1e-6), np.float64: dict(rtol=1e-10, atol=1e-12)}


@pytest.fixture
def tol():
    return TOL
