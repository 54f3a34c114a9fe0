"""The scenario's tracker, composed from its roles, and the tracker and associator doors.

:func:`make` reads the roles of :func:`mjx_radar.scenario.tracker_roles.roles` (filter
form, associator of unlabelled scans, management; docs/tracking.md, "Roles") and builds:

* a registered whole tracker (``[filter] tracker``, :func:`register_tracker`): its
  factory, its :class:`~mjx_radar.env.filter_ops.FilterOps` checked where traced;
* ``management = "managed"``: the track table (:mod:`mjx_radar.env.managed`) with its
  default PDA associator, its joint GNN (``association = "gnn"``), or a registered one;
* an associator on the per-target bank: a built-in's bank (``pda``, ``jpda``, ``gnn``,
  ``mht``: :data:`mjx_radar.registry.ASSOCIATORS`), or a registered one driving the bank
  (:func:`associated_bank`);
* labelled returns: the filter form (``ckf``, ``bank``, ``imm``) of
  :mod:`mjx_radar.env.filter_ops`.

:func:`register_associator` adds an associator ``factory(task, params) -> associate``
(:class:`mjx_radar.contracts.AssociatorFactory`), selected by ``[tracker] association =
"name"``; its code is part of the program cache key, and its mistakes are one-line
:class:`~mjx_radar.contracts.PluginError` s.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from mjx_radar.contracts import PluginError
from mjx_radar.env import filter_ops, managed
from mjx_radar.env.filter_ops import FilterOps
from mjx_radar.estimation.filters import filter_bank, ground_prior
from mjx_radar.estimation.tracks import track_update
from mjx_radar.plugin_errors import failure, guarded_call
from mjx_radar.registry import ASSOCIATORS, TRACKERS
from mjx_radar.scenario import tracker_roles

__all__ = [
    "make",
    "associated_bank",
    "register_tracker",
    "unregister_tracker",
    "register_associator",
    "unregister_associator",
]

_FORMS = {"ckf": filter_ops.joint_ckf, "bank": filter_ops.ckf_bank, "imm": filter_ops.imm_bank}


def make(task, params) -> FilterOps:
    """The scenario's tracker, composed from its roles (module docstring), with the noise
    model of ``params.method``.

    Raises:
        PluginError: one line, for a registered tracker or associator that breaks its
            contract or raises (in its factory, or where its functions are traced).
    """
    r = tracker_roles.roles(task)
    if r.plugin is not None:
        return _plugin_tracker(task, params, r.plugin)
    own = _associator(task, params, r.associator)  # None: a built-in associator
    if r.management == "managed":
        return managed.managed_tracker(task, params, None if own is None else lambda t, p: own)
    if r.associator is None:
        return _FORMS[r.form](task, params)
    if own is not None:
        return associated_bank(task, params, own)
    return ASSOCIATORS.get(r.associator)(task, params)


def _plugin_tracker(task, params, name: str) -> FilterOps:
    """A registered tracker's :class:`FilterOps` (one-line :class:`PluginError` if its
    factory raises or returns anything else; its calls guarded where traced)."""
    factory = TRACKERS.get(name)
    try:
        ops = factory(task, params)
    except PluginError:
        raise
    except Exception as err:  # noqa: BLE001 -- the user's code: one line and its frames
        raise failure("tracker", name, "factory", err) from None
    if not isinstance(ops, FilterOps):
        raise PluginError(
            f"tracker {name!r}: its factory returned {type(ops).__name__}, not FilterOps"
            " (predict, update, begin[, init, tracks])"
        )
    calls = {c: getattr(ops, c) for c in FilterOps._fields if callable(getattr(ops, c))}
    calls = {c: guarded_call("tracker", name, c, f) for c, f in calls.items()}
    for c in ("predict", "update"):
        calls[c] = _checked(name, c, calls[c])
    return ops._replace(**calls)


def _shape_error(kind: str, name: str, call: str, what: str, got, want) -> PluginError:
    return PluginError(
        f"{kind} {name!r}: {call}() returned a {what} of shape {list(jnp.shape(got))}; "
        f"expected {list(want)}"
    )


def _checked(name: str, call: str, fn: Callable) -> Callable:
    """A registered tracker's ``predict`` or ``update``, whose result must be
    ``(mean, cov, modes)`` with the given mean's and cov's shapes (checked where traced)."""

    def checked(mean, cov, modes, *args, **kwargs):
        out = fn(mean, cov, modes, *args, **kwargs)
        if not (isinstance(out, tuple | list) and len(out) == 3):
            got = f"{len(out)} values" if isinstance(out, tuple | list) else type(out).__name__
            raise PluginError(
                f"tracker {name!r}: {call}() returned {got}; expected (mean, cov, modes)"
            )
        for what, given, got in (("mean", mean, out[0]), ("cov", cov, out[1])):
            if jnp.shape(got) != jnp.shape(given):
                raise _shape_error("tracker", name, call, what, got, jnp.shape(given))
        return out

    return checked


def _associator(task, params, name: str | None) -> Callable | None:
    """A registered associator's ``associate``, checked where traced (its shapes, its
    exceptions as one-line :class:`PluginError` s), with ``filter.ground_prior`` applied
    after it; None for a built-in (or no) associator."""
    if not tracker_roles.registered_associator(name):
        return None
    try:
        fn = ASSOCIATORS.get(name)(task, params)
    except PluginError:
        raise
    except Exception as err:  # noqa: BLE001 -- the user's code: one line and its frames
        raise failure("associator", name, "factory", err) from None
    if not callable(fn):
        raise PluginError(
            f"associator {name!r}: its factory returned {type(fn).__name__}, not a function "
            "associate(means, covs, live, zs, valid, radar_pos)"
        )
    fn = guarded_call("associator", name, "associate", fn)
    reflect = jax.vmap(ground_prior.apply_ground_prior)

    def associate(means, covs, live, zs, valid, radar_pos):
        out = fn(means, covs, live, zs, valid, radar_pos)
        if not (isinstance(out, tuple | list) and len(out) == 3):
            got = f"{len(out)} values" if isinstance(out, tuple | list) else type(out).__name__
            raise PluginError(
                f"associator {name!r}: associate() returned {got}; expected (means, covs, nll)"
            )
        nll_shape = (means.shape[0], *valid.shape)
        for what, got, want in zip(
            ("means", "covs", "nll"), out, (means.shape, covs.shape, nll_shape), strict=True
        ):
            if jnp.shape(got) != want:
                raise _shape_error("associator", name, "associate", what, got, want)
        new_means, new_covs, nll = out
        if task.filter.ground_prior:  # honoured as by the built-in associators
            new_means, new_covs = reflect(new_means, new_covs)
        return new_means, new_covs, nll

    return associate


def associated_bank(task, params, associate: Callable) -> FilterOps:
    """The per-target bank (covariance form) whose cluttered scans an ``associate``
    function (:class:`~mjx_radar.contracts.AssociatorFactory`) shares between the M
    targets: every target is a live track; each radar's returns in range order (the
    buffer's order would tell which return is which drone)."""
    bank = filter_ops.ckf_bank(task, params)

    def update(mean, cov, modes, z, radar_pos, scan, los=None):
        if scan.zs is None:  # labelled returns: the bank's update of the detected pairs
            return bank.update(mean, cov, modes, z, radar_pos, scan, los)
        means, covs = filter_bank.joint_to_bank(mean, cov)
        zs, valid = track_update.sorted_scans(scan.zs, scan.valid)
        live = jnp.ones(means.shape[0], bool)
        means, covs, _ = associate(means, covs, live, zs, valid, radar_pos)
        return (*filter_bank.bank_to_joint(means, covs), modes)

    return bank._replace(update=update)


def register_tracker(name: str, factory=None):
    """Registers a tracker: ``factory(task, params) -> FilterOps`` (usable as a decorator).

    Select it in a scenario with ``[filter] tracker = "name"``: it replaces the composed
    roles. Its code is part of the program cache key. Built-ins: ``ckf``, ``bank``,
    ``imm``, ``pda``, ``jpda``, ``gnn``, ``mht``, ``managed`` (docs/extending.md).
    """

    def add(f):
        return TRACKERS.register(name, f)

    return add if factory is None else add(factory)


def unregister_tracker(name: str) -> None:
    """Removes a registered tracker (built-ins stay)."""
    TRACKERS.unregister(name)


def register_associator(name: str, factory=None):
    """Registers an associator: ``factory(task, params) -> associate`` (usable as a decorator).

    ``associate(means [K, 6], covs [K, 6, 6], live [K], zs [N, L, dim], valid [N, L],
    radar_pos [N, 3]) -> (means, covs, nll [K, N, L])``
    (:class:`mjx_radar.contracts.AssociatorFactory`). Select it with ``[tracker]
    association = "name"``: it drives the per-target bank on cluttered scans and the
    managed track table. Its code is part of the program cache key. Built-ins: ``pda``,
    ``jpda``, ``gnn``, ``mht`` (docs/extending.md, ``examples/custom_associator.py``).
    """

    def add(f):
        return ASSOCIATORS.register(name, f)

    return add if factory is None else add(factory)


def unregister_associator(name: str) -> None:
    """Removes a registered associator (built-ins stay)."""
    ASSOCIATORS.unregister(name)
