"""The planner ``policy:DIR``: a trained policy moving the radars like any planner.

``mjx-radar run SCENARIO --planner policy:DIR``, ``mjx-radar study ... --planners
mppi,policy:DIR`` and ``simulate(..., planner="policy:DIR")`` run the policy that
:func:`mjx_radar.learning.train.train_policy` wrote to ``DIR`` (its latest checkpoint),
deterministically (the mode of its action distribution)::

    a = tanh(μ_θ(normalise(features(obs))))          a ∈ [-1, 1]^{2N}
    u = action_to_control(env, a)                     [N, 2] within the radars' limits
    u = shield(env, obs, u)                           if trained with the shield, or
                                                      run as ``shielded-policy:DIR``

One control call is one small MLP evaluation: no rollouts, no objective. The
parameters are read on the host when the planner is made and enter the compiled
program as constants; :meth:`PolicyPlanner.argument_digest` (a digest of the
directory's policy files) is part of the program cache key, so a retrained policy
recompiles. An MLP policy (PPO from scratch) must have been trained with the same
numbers of radars and targets (the features' size; one line otherwise); other scenario
settings may differ (generalisation). A set policy (``network: "set"``, distilled or
fine-tuned from one: :mod:`mjx_radar.learning.set_net`) runs on any numbers::

    a = tanh(SetNet_θ(set_features(obs)))             [N, 2] in [-1, 1]
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from mjx_radar.io.checks import ScenarioError
from mjx_radar.learning.config import read_policy_json
from mjx_radar.learning.features import action_to_control, feature_size, features
from mjx_radar.learning.set_features import set_features
from mjx_radar.learning.shield import shield
from mjx_radar.planners.base import Planner

#: what ``policy.json`` holds (train_policy.py writes it)
KEYS = ("checkpoint", "n_radars", "n_targets", "observation_size", "action_size", "config")
#: what the ``policy.json`` of a set network holds (any fleet size)
SET_KEYS = ("checkpoint", "network", "algo", "scenarios", "config")


def _policy_dir(argument: str, name: str = "policy") -> tuple[Path, dict]:
    """The folder and ``policy.json`` of ``NAME:DIR``, checked (one line otherwise)."""
    path = Path(argument).expanduser().resolve()  # orbax reads absolute paths only
    where = f"planner {name}:{argument}"
    if not path.is_dir():
        raise ScenarioError(f"{where}: no such folder (train_policy.py --out DIR writes one)")
    meta = path / "policy.json"
    if not meta.is_file():
        raise ScenarioError(f"{where}: no policy.json (train_policy.py --out)")
    state = read_policy_json(meta, where)
    if not state.get("checkpoint"):
        raise ScenarioError(f"{where}: no checkpoint saved yet")
    need = SET_KEYS if state.get("network") == "set" else KEYS
    missing = [k for k in need if k not in state]
    if missing:
        raise ScenarioError(f"{where}: {meta} lacks {', '.join(missing)} (damaged or edited)")
    if not (path / str(state["checkpoint"])).is_dir():
        raise ScenarioError(
            f"{where}: its checkpoint {state['checkpoint']!r} is missing from {path}"
        )
    return path, state


class PolicyPlanner(Planner):
    """A policy trained by ``scripts/train_policy.py`` (module docstring).

    Args:
        env: the environment whose radars it moves.
        argument: the policy directory ``DIR`` (``policy:DIR``).
    """

    takes_argument = True
    argument_name = "DIR"  # "give policy:DIR"
    registry_name = "policy"  # what error lines call it

    def __init__(self, env, argument: str):
        super().__init__(env)
        path, state = _policy_dir(argument, self.registry_name)
        self.source, self.state = str(path), state
        if state.get("network") == "set":  # any fleet size (learning.set_net)
            self.shielded = bool(state["config"].get("shield", False))
            self._policy = load_set_policy(path / state["checkpoint"], state)
            return
        n, m = env.n_radars, env.n_targets
        if (state["n_radars"], state["n_targets"]) != (n, m):
            raise ScenarioError(
                f"planner {self.registry_name}:{argument}: trained for {state['n_radars']} "
                f"radars and {state['n_targets']} targets ({state.get('scenario', '?')}), "
                f"not {n} and {m}"
            )
        if state["observation_size"] != feature_size(n, m):
            raise ScenarioError(
                f"planner {self.registry_name}:{argument}: features of another version"
            )
        self.shielded = bool(state["config"].get("shield", False))  # as trained
        self._policy = load_policy(path / state["checkpoint"], state)

    def plan(self, carry, obs, key):
        if self.state.get("network") == "set":
            a = self._policy(set_features(self.env, obs, _features(self.state))).reshape(-1)
        else:
            a, _ = self._policy(features(self.env, obs), key)
        u = action_to_control(self.env, a)
        if self.shielded:
            u = shield(self.env, obs, u)
        return u.astype(obs.mean.dtype), carry

    @classmethod
    def argument_digest(cls, argument: str) -> str:
        """A digest of ``DIR/policy.json`` and the files of its latest checkpoint (a
        distillation's ``state.npz``, its buffers and optimiser, left out)."""
        path, state = _policy_dir(argument, cls.registry_name)
        h = hashlib.sha256((path / "policy.json").read_bytes())
        for f in sorted((path / state["checkpoint"]).rglob("*")):
            if f.is_file() and f.name != "state.npz":  # a distillation's buffers: not the policy
                h.update(f.relative_to(path).as_posix().encode())
                h.update(f.read_bytes())
        return h.hexdigest()[:16]


class ShieldedPolicyPlanner(PolicyPlanner):
    """``shielded-policy:DIR``: the policy of ``DIR`` with the keep-out shield
    (:func:`~mjx_radar.learning.shield.shield`) on its controls, whether or not it was
    trained with it (a safety layer added at deployment only)."""

    registry_name = "shielded-policy"

    def __init__(self, env, argument: str):
        super().__init__(env, argument)
        self.shielded = True


def load_policy(checkpoint, state: dict):
    """``policy(features [F], key) -> (action [2N], extras)`` of a brax PPO checkpoint
    (deterministic: the mode), its parameters as constants.

    The network is rebuilt from ``policy.json``'s configuration (brax 0.14's
    ``load_config`` fails on the ``None`` kernel initialiser it saves itself)."""
    try:
        from brax.training.acme import running_statistics
        from brax.training.agents.ppo import checkpoint as ppo_ckpt
        from brax.training.agents.ppo import networks
    except ImportError:
        raise ScenarioError(
            "planner policy: needs the rl extra (pip install -e '.[rl]': brax)"
        ) from None
    from mjx_radar.learning.config import config_of, network_factory

    network = network_factory(config_of(state))(
        state["observation_size"],
        state["action_size"],
        preprocess_observations_fn=running_statistics.normalize,
    )
    try:
        params = ppo_ckpt.load(checkpoint)
    except Exception as err:  # noqa: BLE001 -- a damaged checkpoint: one line naming it
        raise ScenarioError(
            f"planner policy: checkpoint {checkpoint} cannot be read ({type(err).__name__}: "
            f"{str(err).splitlines()[0] if str(err) else ''})"
        ) from None
    return networks.make_inference_fn(network)(params, deterministic=True)


def _features(state: dict) -> str:
    """The set features' version a set policy was trained on (a fine-tuned one: its
    distillation's)."""
    return state.get("distill_config", state["config"]).get("features", "v1")


def load_set_policy(checkpoint, state: dict):
    """``policy(SetObs) -> action [N, 2]`` of a set network's checkpoint (a distilled
    one, ``params.npz``, or a PPO fine-tuned one, brax's), deterministic, its parameters
    as constants."""
    import jax

    from mjx_radar.learning.distill_ckpt import load_leaves
    from mjx_radar.learning.set_net import init_params, policy_action

    hidden = int(state["config"]["hidden"])
    template = init_params(hidden, jax.random.PRNGKey(0), False, _features(state))
    if (checkpoint / "params.npz").is_file():  # distilled (not fine-tuned yet)
        params = load_leaves(checkpoint / "params.npz", template)
    else:
        from mjx_radar.learning.set_ppo import load_ppo_set_params

        params = load_ppo_set_params(checkpoint, template)
    return lambda x: policy_action(params, x, hidden)
