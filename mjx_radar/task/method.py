"""Methods (SPEC §9) as typed values, parsed once at the CLI / report boundary.

A :class:`Method` says what the closed loop does: which noise model the planner and
the filter assume (``noise``: DDR, the truth, or the constant CCR baseline) and
which information the planner maximises (``info``: SFIM, PFIM, or ``none`` for
radars that never move). Below the boundary no code looks at a method's name.

Inside a compiled program a method is a :class:`MethodFlags` pytree of unbatched
runtime scalars. What a program compiles of the planner is static, its *program
kind* (:data:`PROGRAM_KINDS`, the method's ``info``): ``"none"`` compiles no planner
at all, ``"sfim"`` / ``"pfim"`` only that information, so CCR and DDR methods of an
information kind share a program (``ccr`` stays a runtime flag). Kind ``"all"``
serves every method: both information branches joined by ``lax.cond`` on the runtime
flags (an unbatched predicate stays a branch under ``vmap``).

Adding a method is one line in :data:`METHODS`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

NOISE_MODELS = ("ddr", "ccr")
INFO_KINDS = ("sfim", "pfim", "none")
#: what a compiled program carries of the planner: one information kind, or all methods
PROGRAM_KINDS = ("none", "sfim", "pfim", "all")


@dataclass(frozen=True)
class Method:
    """A closed-loop method.

    Attributes:
        name: the name users type (``mjx-radar run --method NAME``).
        noise: ``"ddr"`` (variance ``C d⁴``, the truth) or ``"ccr"`` (constant
            ``C R2T⁴``): the model of the planner's information and of the filter.
        info: ``"sfim"``, ``"pfim"`` or ``"none"`` (no planner: radars stay put).
    """

    name: str
    noise: str
    info: str

    def __post_init__(self):
        if self.noise not in NOISE_MODELS:
            raise ValueError(f"method {self.name}: noise = {self.noise!r} not in {NOISE_MODELS}")
        if self.info not in INFO_KINDS:
            raise ValueError(f"method {self.name}: info = {self.info!r} not in {INFO_KINDS}")

    @property
    def plans(self) -> bool:
        """Whether MPPI moves the radars."""
        return self.info != "none"

    @property
    def kind(self) -> str:
        """The program kind that runs this method (its information kind)."""
        return self.info

    def flags(self) -> MethodFlags:
        """The method as runtime scalars for a compiled program."""
        import jax.numpy as jnp

        return MethodFlags(
            ccr=jnp.asarray(self.noise == "ccr"),
            pfim=jnp.asarray(self.info == "pfim"),
            plans=jnp.asarray(self.plans),
        )


class MethodFlags(NamedTuple):
    """A method inside a compiled program (unbatched bool scalars)."""

    ccr: Any  # filter and planner assume the constant CCR variance
    pfim: Any  # planner maximises the PFIM (else the SFIM)
    plans: Any  # MPPI moves the radars (else they stay put)


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


def parse_method(name: str | Method) -> Method:
    """The :class:`Method` called ``name``; a one-line ``ValueError`` for an unknown name."""
    if isinstance(name, Method):
        return name
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise ValueError(f"method: {name!r} is not one of {', '.join(METHODS)}") from None


def baseline_of(method: Method) -> Method | None:
    """The CCR method with the same information kind as a DDR one (the paper's comparison)."""
    if method.noise != "ddr" or not method.plans:
        return None
    return next((m for m in METHODS.values() if m.noise == "ccr" and m.info == method.info), None)


def normalise_methods(names) -> list[str]:
    """Canonical method names, case-insensitive, each once in order of first appearance.

    Raises:
        ValueError: an unknown name, a non-string or an empty list (one line).
    """
    out = []
    for name in names:
        key = name.strip().lower() if isinstance(name, str) else name
        if key not in METHODS:
            raise ValueError(f"methods: {name!r} is not one of {', '.join(METHODS)}")
        out.append(key)
    if not out:
        raise ValueError("methods: empty list")
    return list(dict.fromkeys(out))
