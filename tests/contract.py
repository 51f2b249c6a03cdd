"""The trust contract every estimate keeps, asserted by the dispersion altimeter's tests."""

from __future__ import annotations

import numpy as np

from wavealt.altimetry.dispersion import MAX_TRUSTED_3SIGMA


def assert_honest(res, true_alt: float) -> None:
    """3 sigma covers the error; trusted means within 10 % and a 3-sigma interval no wider
    than that; untrusted says why."""
    err = abs(res.altitude_m - true_alt)
    assert err <= 3.0 * res.altitude_std_m, (res, true_alt)
    if res.trusted:
        assert res.reason is None
        assert err / true_alt <= 0.10, (res, true_alt)
        assert 3.0 * res.altitude_std_m / res.altitude_m <= np.log1p(MAX_TRUSTED_3SIGMA) + 1e-12
    else:
        assert isinstance(res.reason, str) and res.reason
