"""Every loader on real (or vendor-layout) samples, and malformed variants of each."""

import numpy as np
import pytest

from groundplane.beam import Beam, BeamFormatError


def test_beam_validation():
    with pytest.raises(BeamFormatError, match="shape"):
        Beam([50.0], np.arange(91.0), np.arange(360.0), np.ones((1, 90, 360)))
    with pytest.raises(BeamFormatError, match="360 = 0"):
        Beam([50.0], np.arange(91.0), np.arange(361.0), np.ones((1, 91, 361)))
    with pytest.raises(BeamFormatError, match="not finite"):
        g = np.ones((1, 91, 360))
        g[0, 3, 4] = np.nan
        Beam([50.0], np.arange(91.0), np.arange(360.0), g)

def test_solid_angle_weights_cover_hemisphere():
    b = Beam([50.0], np.arange(91.0), np.arange(360.0), np.ones((1, 91, 360)))
    assert b.solid_angle_weights().sum() == pytest.approx(2 * np.pi, rel=1e-12)

