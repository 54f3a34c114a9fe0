"""Cost terms registered from scripts (``mjx_radar.register_cost_term``).

A registered term joins :data:`mjx_radar.registry.COST_TERMS`, the one registry of cost
terms (the built-in ones are listed there too): every objective built afterwards whose
scenario it is ``enabled`` for gets it after the built-in terms
(:func:`mjx_radar.task.costs.cost_terms`), and its code is part of every program cache key
(:func:`registry_key`), so editing a term recompiles instead of reusing a stale program.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from mjx_radar.contracts import PluginError, takes
from mjx_radar.registry import COST_TERMS

__all__ = [
    "RegisteredTerm",
    "register_cost_term",
    "registered",
    "registry_key",
    "unregister_cost_term",
]

#: the built-in terms' names (:data:`mjx_radar.registry.COST_TERMS`), which no script may take
BUILT_IN = COST_TERMS.names()


class RegisteredTerm:
    """A cost term registered from a script, as :data:`mjx_radar.registry.COST_TERMS`
    holds it: ``term(h, task, params) -> [H]`` calls the user's ``fn`` (its own exception
    a one-line :class:`~mjx_radar.contracts.PluginError`, its result's shape checked) and
    :meth:`applies` the user's ``enabled(scenario)``. Its code digest is that of ``fn``
    and ``enabled`` (:func:`mjx_radar.registry.code_digest`)."""

    def __init__(self, name: str, fn: Callable, enabled: Callable | None):
        from mjx_radar.plugin_errors import guarded_call

        self.name, self.fn, self.enabled = name, fn, enabled or _every_scenario
        self._fn = guarded_call("cost term", name, getattr(fn, "__name__", name), fn)
        self._enabled = guarded_call("cost term", name, "enabled", self.enabled)

    def __call__(self, h, task, params) -> jax.Array:  # one cost per horizon step
        out = self._fn(h, task, params)
        if jnp.shape(out) != jnp.shape(h.controls)[:1]:
            raise PluginError(
                f"cost term {self.name!r}: returned shape {list(jnp.shape(out))}; expected "
                f"[{jnp.shape(h.controls)[0]}] (one cost per horizon step)"
            )
        return out

    def applies(self, scenario) -> bool:
        """Whether the term is in ``scenario``'s objective (``enabled(scenario)``)."""
        return bool(self._enabled(scenario))

    def code_parts(self) -> tuple[Callable, Callable]:
        return self.fn, self.enabled


def _every_scenario(scenario) -> bool:
    return True


def register_cost_term(
    name: str,
    fn: Callable[[Any, Any, Any], jax.Array],
    enabled: Callable[[Any], bool] | None = None,
) -> None:
    """Adds a cost term to every objective built afterwards (replacing one of that name).

    The term joins :data:`mjx_radar.registry.COST_TERMS`, the registry of every cost term.

    Args:
        name: the term's name in ``Plan.terms`` (not a built-in term's name).
        fn: ``fn(h: Horizon, task, params) -> [H]`` per-step cost (undiscounted), pure JAX
            (:class:`mjx_radar.contracts.CostTermPlugin`).
        enabled: ``enabled(scenario) -> bool``: the scenarios whose objective gets the term
            (default all).

    The term's code (and the scalar globals and closure values it reads) is part of the
    program caches' keys, so changing it recompiles; other state it reads is not.

    Example:
        >>> def stay_home(h, task, params):  # metres beyond 300 m from the origin
        ...     r = jnp.linalg.norm(h.radar[..., :2], axis=-1)  # [H, N]
        ...     return 10.0 * jax.nn.relu(r - 300.0).sum(-1)
        >>> register_cost_term("stay_home", stay_home)
    """
    from mjx_radar.contracts import PluginError

    if not isinstance(name, str) or not name.isidentifier() or name.lower() in BUILT_IN:
        raise ValueError(f"cost term name {name!r}: must be an identifier, not a built-in term")
    if not callable(fn) or (enabled is not None and not callable(enabled)):
        raise TypeError(f"cost term {name!r}: fn and enabled must be callables")
    for f, n, args in ((fn, 3, "(h, task, params)"), (enabled, 1, "(scenario)")):
        if f is not None and not takes(f, n):
            what = getattr(f, "__name__", type(f).__name__)
            raise PluginError(f"cost term {name!r}: {what}() must take {args}")
    COST_TERMS.register(name, RegisteredTerm(name, fn, enabled))


def unregister_cost_term(name: str) -> None:
    """Removes a registered term (no error if absent)."""
    COST_TERMS.unregister(name)


def registry_key() -> tuple:
    """``((name, code digest), ...)`` of the registered terms: part of every cache key."""
    return COST_TERMS.key()


def registered() -> tuple[RegisteredTerm, ...]:
    """The registered terms, in order of registration."""
    return tuple(COST_TERMS.registered().values())
