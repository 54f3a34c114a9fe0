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
flags (an unbatched predicate stays a branch under ``vmap``); ``"sfim+none"`` and
``"pfim+none"`` serve one information kind and ``stationary`` (plan or hold, a
``lax.cond`` on ``plans``); :data:`SWITCH` (``"sfim+pfim+none"``) serves every
built-in method: hold, or each information's whole planner, by a runtime switch. A study
runs the built-in methods of one scenario shape in one such program
(:func:`shared_programs`): the fixed loop (truth, filter, metrics), the larger part of a
program, is compiled once per shape, and every method's numbers are those of its own
program bit for bit.

A method is planner x information x noise model: ``planner`` names the registered
planner (:mod:`mjx_radar.planners`) that moves the radars -- the paper's MPPI for the
four planning methods, ``hold`` for ``stationary``. ``"ddr-sfim+NAME"`` is the method
``ddr-sfim`` with the planner ``NAME`` (:func:`parse_method`); the five paper names are
aliases of their default planners. Adding a method is one line in :data:`METHODS`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

NOISE_MODELS = ("ddr", "ccr")
INFO_KINDS = ("sfim", "pfim", "none")
#: every built-in method in one program: hold, or each information's whole planner, by a
#: runtime switch (a study's program per shape; the numbers of each method's own program)
SWITCH = "sfim+pfim+none"
#: what a compiled program carries of the planner: one information kind, several, or all
PROGRAM_KINDS = ("none", "sfim", "pfim", "sfim+none", "pfim+none", SWITCH, "all")
#: the planners whose methods share a program of several kinds (the built-in ones)
SHARING_PLANNERS = ("mppi", "hold")


@dataclass(frozen=True)
class Method:
    """A closed-loop method.

    Attributes:
        name: the name users type (``mjx-radar run --method NAME``).
        noise: ``"ddr"`` (variance ``C d⁴``, the truth) or ``"ccr"`` (constant
            ``C R2T⁴``): the model of the planner's information and of the filter.
        info: ``"sfim"``, ``"pfim"`` or ``"none"`` (no planner: radars stay put).
        planner: the registered planner that moves the radars (``"mppi"``, ``"hold"``,
            or a name given to :func:`mjx_radar.register_planner`).
    """

    name: str
    noise: str
    info: str
    planner: str = "mppi"

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
        Method("stationary", "ddr", "none", planner="hold"),
        Method("ccr-sfim", "ccr", "sfim"),
        Method("ccr-pfim", "ccr", "pfim"),
        Method("ddr-sfim", "ddr", "sfim"),
        Method("ddr-pfim", "ddr", "pfim"),
    )
}


def parse_method(name: str | Method, planner: str | None = None) -> Method:
    """The :class:`Method` called ``name`` (``"ddr-sfim"`` or ``"ddr-sfim+PLANNER"``).

    Args:
        name: a method name or :class:`Method`.
        planner: a planner replacing the method's (None: the method's own).

    Raises:
        ValueError: one line for an unknown method, or a planner given to ``stationary``.
    """
    if isinstance(name, Method):
        method = name
    else:
        base, _, own = name.partition("+") if isinstance(name, str) else (name, "", "")
        try:
            method = METHODS[base]
        except (KeyError, TypeError):
            raise ValueError(f"method: {name!r} is not one of {', '.join(METHODS)}") from None
        if own and planner is not None and planner_name(planner) != planner_name(own):
            raise ValueError(
                f"planner: {planner!r} conflicts with the method {name!r}, which names its "
                f"planner {own!r}; give one of them"
            )
        planner = own or planner
    return with_planner(method, planner)


def with_planner(method: Method, planner: str | None) -> Method:
    """``method`` moved by ``planner`` (named ``"METHOD+PLANNER"``; None: unchanged)."""
    if not isinstance(planner, str | None) or planner == "":
        raise ValueError(f"planner: {planner!r} is not a planner name")
    planner = planner_name(planner)
    if planner is None or planner == method.planner:
        return method
    if not method.plans:
        raise ValueError(
            f"planner: {method.name!r} radars never move; give --planner a planning method "
            "(e.g. ddr-sfim)"
        )
    base = method.name.partition("+")[0]
    default = METHODS[base].planner if base in METHODS else "mppi"
    name = base if planner == default else f"{base}+{planner}"
    return Method(name, method.noise, method.info, planner)


def planner_name(planner: str | None) -> str | None:
    """A planner name as the registry keeps it: case-insensitive (``"CEM"`` is ``"cem"``),
    a ``:ARGUMENT`` (``policy:DIR``) kept as given."""
    if not isinstance(planner, str):
        return planner
    base, colon, arg = planner.strip().partition(":")
    return base.lower() + colon + arg


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
        key, plus, planner = (
            name.strip().partition("+") if isinstance(name, str) else (name, "", "")
        )
        key = key.lower() if isinstance(key, str) else key
        if key not in METHODS:
            raise ValueError(f"methods: {name!r} is not one of {', '.join(METHODS)}")
        out.append(parse_method(key, planner or None).name if plus else key)
    if not out:
        raise ValueError("methods: empty list")
    return list(dict.fromkeys(out))


def with_planners(names, planners) -> list[str]:
    """Every method of ``names`` under every planner of ``planners`` (``study --planners``).

    A method that never moves its radars (``stationary``) is kept once, as it is; the
    planner ``mppi`` keeps the paper's names. Raises one-line ``ValueError`` as
    :func:`parse_method`, and when planners are given but no method plans (they would
    be dropped).
    """
    if planners and names and not any(parse_method(n).plans for n in names):
        raise ValueError(
            f"{', '.join(map(str, planners))} given, but no method of {', '.join(names)} "
            "plans ('stationary' radars never move); add a planning method (e.g. ddr-sfim)"
        )
    out = []
    for name in names:
        method = parse_method(name)
        if not method.plans or not planners:
            out.append(method.name)
            continue
        out += [parse_method(method, p).name for p in planners]
    return list(dict.fromkeys(out))


def information_of(kind: str) -> str | None:
    """The one information a program of ``kind`` maximises (``"sfim"``, ``"pfim"``), or
    None: no planner (``"none"``) or both behind a runtime branch (``"all"``)."""
    infos = set(kind.split("+")) & {"sfim", "pfim"}
    return infos.pop() if len(infos) == 1 else None


def plans_optional(kind: str) -> bool:
    """Whether a program of ``kind`` plans or holds by the runtime flag ``plans``."""
    return kind == "all" or (kind != "none" and "none" in kind.split("+"))


def served(kind: str) -> set[str]:
    """The information kinds of the methods a program of ``kind`` runs."""
    return {"sfim", "pfim", "none"} if kind == "all" else set(kind.split("+"))


def runs(program: tuple[str, str], method: Method) -> bool:
    """Whether the program ``(kind, planner)`` runs ``method``: its own, or a shared
    one of the built-in planners whose kind serves the method's (:func:`shared_programs`)."""
    kind, planner = program
    if (kind, planner) == (method.kind, method.planner):
        return True
    shared = method.planner in SHARING_PLANNERS and planner == "mppi"
    return shared and kind in PROGRAM_KINDS and method.kind in served(kind)


def shared_programs(methods) -> dict[str, tuple[str, str]]:
    """``{method name: (program kind, planner)}`` for methods run on one scenario shape.

    The methods of the built-in planners (:data:`SHARING_PLANNERS`: MPPI and the
    stationary radars' ``hold``) share one program: of their one information kind, with
    ``"+none"`` when stationary radars ride along (plan or hold by the runtime flag
    ``plans``), or :data:`SWITCH` for both informations (each information's whole planner
    in a branch of a runtime switch). Each method gets the numbers of its own program bit
    for bit; one ``"all"`` program (both informations behind a branch inside the
    objective) does not (CCR-PFIM differs by float32 round-off). Registered planners, and
    a built-in method alone, keep their own programs.
    """
    ms = [parse_method(m) for m in methods]
    built_in = [m for m in ms if m.planner in SHARING_PLANNERS]
    kinds = {m.kind for m in built_in}
    infos = sorted(kinds - {"none"}, key=("sfim", "pfim").index)
    if len(infos) == 2:
        shared = SWITCH
    elif infos:
        shared = infos[0] + ("+none" if "none" in kinds else "")
    else:
        shared = "none"
    out = {}
    for m in ms:
        if m.planner in SHARING_PLANNERS and shared != m.kind:
            out[m.name] = (shared, "mppi")
        else:
            out[m.name] = (m.kind, m.planner)
    return out
