"""The five methods of the study as typed values (SPEC §9).

A method is a filter/planner noise model and an information kind:

========== ======= ======
name       noise   info
========== ======= ======
stationary ddr     none    (radars never move; the filter uses the true DDR model)
ccr-sfim   ccr     sfim
ccr-pfim   ccr     pfim
ddr-sfim   ddr     sfim
ddr-pfim   ddr     pfim
========== ======= ======
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Method", "METHODS", "parse_method"]


@dataclass(frozen=True)
class Method:
    """One method: ``noise`` in {"ddr", "ccr"}, ``info`` in {"sfim", "pfim", "none"}."""

    name: str
    noise: str
    info: str

    @property
    def plans(self) -> bool:
        """True when MPPI moves the radars (``info != "none"``)."""
        return self.info != "none"


METHODS: dict[str, Method] = {
    m.name: m
    for m in (
        Method("stationary", "ddr", "none"),
        Method("ccr-sfim", "ccr", "sfim"),
        Method("ccr-pfim", "ccr", "pfim"),
        Method("ddr-sfim", "ddr", "sfim"),
        Method("ddr-pfim", "ddr", "pfim"),
    )
}


def parse_method(name: str) -> Method:
    """The :class:`Method` called ``name``; ValueError (one line) for an unknown name."""
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise ValueError(f"method: {name!r} is not one of {', '.join(METHODS)}") from None
