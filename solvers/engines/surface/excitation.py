"""The excitation and its result: a delta gap across the feed edges, and the basis currents,
input current, impedance and power it drives (whichever assembler solved it)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .operators import Problem


@dataclass
class Solution:
    """Basis currents (A/m across each edge) at one frequency, the input current and power."""

    freq_hz: float
    currents: np.ndarray
    input_current: complex
    volts: float

    @property
    def input_impedance(self) -> complex:
        return self.volts / self.input_current

    @property
    def input_power(self) -> float:
        return 0.5 * float(np.real(self.volts * np.conj(self.input_current)))


def feed_signs(prob: Problem, direction: tuple[float, float] = (1.0, 0.0)) -> np.ndarray:
    """+-1 per feed edge so every driven edge pushes current along ``direction`` (the
    basis runs from its plus to its minus triangle; edge orientation is arbitrary)."""
    cen = prob.mesh.centroids[:, :2]
    run = cen[prob.rwg.minus[prob.rwg.feed]] - cen[prob.rwg.plus[prob.rwg.feed]]
    return np.where(run @ np.asarray(direction) >= 0, 1.0, -1.0)
