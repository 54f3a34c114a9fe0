"""A planner's outputs checked where the closed loop is traced.

:func:`guarded` makes the planner ``name`` for an environment and wraps it: every
call goes to the planner unchanged (the traced program is the same), and its results
are checked on their *shapes*, which are static under ``jit``, so the checks cost
nothing at run time and never alter a number:

* ``plan(carry, obs, key)`` returns a pair ``(action, carry)``;
* ``action`` is ``[N, 2]`` (or ``[2N]``) floating point, ``N = env.n_radars``;
* the returned carry has the structure, shapes and dtypes of ``init()``'s (what
  ``lax.scan`` needs of a loop carry).

After a run, :func:`check_controls` refuses a registered planner's NaN or inf controls
(before anything is written: its trials would only diverge).

A mistake is a one-line :class:`~mjx_radar.contracts.PluginError` naming the planner,
what was expected and what was received. A registered planner's own exception (in
``__init__``, ``init``, ``plan``, ``record``) becomes one line naming the planner and
the call, with the user's own frames (:func:`mjx_radar.plugin_errors.failure`).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.contracts import PluginError
from mjx_radar.plugin_errors import failure
from mjx_radar.registry import PLANNERS


def _spec(tree) -> tuple:
    leaves, treedef = jax.tree_util.tree_flatten(tree)
    return treedef, [(jnp.shape(x), jnp.result_type(x)) for x in leaves]


def _describe(leaves) -> str:
    text = ", ".join(f"{d}{list(s)}" for s, d in leaves)
    return text if len(text) <= 120 else text[:117] + "..."


class GuardedPlanner:
    """A planner whose results are checked at trace time (other attributes pass through).

    Args:
        name: the registered name (for messages).
        inner: the planner made for ``env``.
        env: the environment (``env.n_radars``).
        user: whether the planner is a registered plug-in (its exceptions are explained).
    """

    def __init__(self, name: str, inner: Any, env: Any, user: bool):
        self._name, self._inner, self._env, self._user = name, inner, env, user
        self._carry_spec = None

    def __getattr__(self, attr: str):
        return getattr(self._inner, attr)

    def _call(self, call: str, *args):
        fn = getattr(self._inner, call, None)
        if fn is None:
            raise PluginError(
                f"planner {self._name!r}: {type(self._inner).__name__} has no {call}()"
            )
        if not self._user:
            return fn(*args)
        try:
            return fn(*args)
        except PluginError:
            raise
        except Exception as err:  # noqa: BLE001 -- the user's code: one line and its frames
            raise failure("planner", self._name, call, err) from None

    def init(self):
        carry = self._call("init")
        self._carry_spec = _spec(carry)
        return carry

    def plan(self, carry, obs, key):
        out = self._call("plan", carry, obs, key)
        if not (isinstance(out, tuple) and len(out) == 2):
            got = f"a tuple of {len(out)}" if isinstance(out, tuple) else type(out).__name__
            if hasattr(out, "shape"):
                got = f"one array of shape {list(jnp.shape(out))}"
            raise PluginError(
                f"planner {self._name!r}: plan() must return (action, carry), got {got}"
                " (return the carry too)"
            )
        action, new = out
        n = self._env.n_radars
        shape = jnp.shape(action) if hasattr(action, "shape") or _is_numeric(action) else None
        if shape is None or tuple(shape) not in ((n, 2), (2 * n,)):
            got = list(shape) if shape is not None else type(action).__name__
            raise PluginError(
                f"planner {self._name!r}: plan() returned an action of shape {got}; expected "
                f"[{n}, 2] ([a, alpha] per radar, {n} radar(s))"
            )
        if not jnp.issubdtype(jnp.result_type(action), jnp.floating):
            raise PluginError(
                f"planner {self._name!r}: plan() returned a {jnp.result_type(action)} action; "
                "expected floating point"
            )
        self._check_carry(carry, new)
        return action, new

    def _check_carry(self, given, returned) -> None:
        want = self._carry_spec or _spec(given)
        got = _spec(returned)
        if got[0] != want[0]:
            raise PluginError(
                f"planner {self._name!r}: plan() returned a carry of structure {got[0]}; "
                f"expected init()'s {want[0]}"
            )
        for (s1, d1), (s2, d2) in zip(got[1], want[1], strict=True):
            if tuple(s1) != tuple(s2) or d1 != d2:
                raise PluginError(
                    f"planner {self._name!r}: plan() returned a carry of {_describe(got[1])}; "
                    f"expected init()'s {_describe(want[1])}"
                )

    def record(self, carry, action):
        return self._call("record", carry, action)


def _is_numeric(x) -> bool:
    return isinstance(x, int | float | list | tuple)


def guarded(name: str, env) -> GuardedPlanner:
    """The planner ``name`` made for ``env``, checked (:class:`GuardedPlanner`)."""
    factory = PLANNERS.get(name)
    base = name.partition(":")[0].lower() if isinstance(name, str) else name
    user = base in PLANNERS.registered()
    if not user:
        return GuardedPlanner(name, factory(env), env, False)
    try:
        inner = factory(env)
    except PluginError:
        raise
    except Exception as err:  # noqa: BLE001 -- the user's code: one line and its frames
        raise failure("planner", name, "__init__", err) from None
    if inner is None or not callable(getattr(inner, "plan", None)):
        raise PluginError(
            f"planner {name!r}: its factory returned {type(inner).__name__}, "
            "not a planner with init() and plan()"
        )
    return GuardedPlanner(name, inner, env, True)


def check_controls(method: str, controls, trials) -> None:
    """Refuses NaN or inf in the controls ``[T, J, N, 2]`` of a registered planner (method
    ``METHOD+NAME``): one :class:`PluginError` line naming the planner, trial and period."""
    name = method.partition("+")[2] if isinstance(method, str) else ""
    if controls is None or name.partition(":")[0].lower() not in PLANNERS.registered():
        return
    c = np.asarray(controls)
    bad = ~np.isfinite(c.reshape(c.shape[0], c.shape[1], -1)).all(axis=-1)  # [T, J]
    if bad.any():
        t, j = (int(i[0]) for i in np.nonzero(bad))
        raise PluginError(
            f"planner {name!r}: plan() returned NaN or inf controls (first at trial "
            f"{int(np.asarray(trials)[t])}, control period {j}); every control must be finite"
        )
