"""The set network as brax PPO's networks: PPO fine-tuning of a distilled policy.

brax's PPO takes a ``network_factory(observation_size, action_size,
preprocess_observations_fn, **kwargs) -> PPONetworks``. :func:`make_set_ppo_networks`
builds one on :class:`~mjx_radar.learning.set_net.SetNet`: the observation is the
flattened :class:`~mjx_radar.learning.set_features.SetObs` of N radars and M targets
(``BraxRadarEnv(observation="set")``), unflattened inside; the policy's parameters are
``{"net": SetNet params, "std": []}`` and its output the tanh-normal distribution's
``[loc (2N), raw scale (2N)]``, the scale one shared number (brax's ``softplus(raw) +
0.001``), so its mode ``tanh(loc)`` is the distilled policy's action. The value is the
set network's value head. :func:`distilled_params` puts a distilled policy's parameters
where ``ppo.train(restore_params=...)`` starts from (the value head fresh).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from brax.training import distribution, networks, types
from brax.training.acme import running_statistics, specs
from brax.training.agents.ppo import networks as ppo_networks

from mjx_radar.learning.set_features import flat_size, unflatten
from mjx_radar.learning.set_net import SetNet, init_params

_MIN_STD = 0.001  # brax's NormalTanhDistribution


def raw_std(std: float) -> float:
    """The raw scale whose ``softplus(raw) + 0.001`` is ``std``."""
    s = max(std - _MIN_STD, 1e-6)
    return float(np.log(np.expm1(s)))


def _batched(fn, n: int, m: int, version: str = "v1"):
    """``fn`` of one SetObs applied over any leading axes of flat observations."""

    def apply(obs):
        lead = obs.shape[:-1]
        x = unflatten(obs.reshape((-1, obs.shape[-1])), n, m, version)
        out = jax.vmap(fn)(x)
        return out.reshape(lead + out.shape[1:])

    return apply


def make_set_ppo_networks(
    observation_size,
    action_size: int,
    preprocess_observations_fn: types.PreprocessObservationFn = (
        types.identity_observation_preprocessor
    ),
    *,
    n_radars: int = 1,
    n_targets: int = 1,
    hidden: int = 64,
    init_noise_std: float = 0.3,
    features: str = "v1",
) -> ppo_networks.PPONetworks:
    """brax :class:`PPONetworks` of the set network (module docstring) for N, M and the
    set features of version ``features``."""
    n, m = n_radars, n_targets
    if isinstance(observation_size, tuple | list):  # brax passes the shape
        observation_size = observation_size[-1]
    if observation_size != flat_size(n, m, features) or action_size != 2 * n:
        raise ValueError(f"set network: observation {observation_size}, action {action_size}")
    pnet, vnet = SetNet(hidden), SetNet(hidden, value=True)

    def policy_init(key):
        return {
            "net": pnet.init(key, unflatten(jnp.zeros(observation_size), n, m, features)),
            "std": jnp.float32(raw_std(init_noise_std)),
        }

    def policy_apply(processor_params, params, obs):
        obs = preprocess_observations_fn(obs, processor_params)
        loc = _batched(lambda x: pnet.apply(params["net"], x).reshape(-1), n, m, features)(obs)
        return jnp.concatenate([loc, jnp.broadcast_to(params["std"], loc.shape)], -1)

    def value_apply(processor_params, params, obs):
        obs = preprocess_observations_fn(obs, processor_params)
        return _batched(lambda x: vnet.apply(params, x), n, m, features)(obs)

    return ppo_networks.PPONetworks(
        policy_network=networks.FeedForwardNetwork(init=policy_init, apply=policy_apply),
        value_network=networks.FeedForwardNetwork(
            init=lambda key: init_params(hidden, key, True, features), apply=value_apply
        ),
        parametric_action_distribution=distribution.NormalTanhDistribution(event_size=action_size),
    )


def set_network_factory(n: int, m: int, hidden: int, init_noise_std: float, features: str = "v1"):
    """:func:`make_set_ppo_networks` for N radars, M targets (brax's ``network_factory``)."""
    return functools.partial(
        make_set_ppo_networks,
        n_radars=n,
        n_targets=m,
        hidden=hidden,
        init_noise_std=float(init_noise_std),
        features=features,
    )


def distilled_params(
    params, n: int, m: int, hidden: int, init_noise_std: float, key, features: str = "v1"
):
    """``(normaliser, policy, value)`` for ``ppo.train(restore_params=...)``: the
    distilled set network, the noise ``init_noise_std``, a fresh value head."""
    spec = specs.Array((flat_size(n, m, features),), jnp.dtype("float32"))
    policy = {"net": params, "std": jnp.float32(raw_std(init_noise_std))}
    value = init_params(hidden, key, True, features)
    return running_statistics.init_state(spec), policy, value


def load_ppo_set_params(checkpoint, template):
    """The set network's parameters (``template``'s structure) of a fine-tuned policy's
    brax checkpoint."""
    from brax.training.agents.ppo import checkpoint as ppo_ckpt

    policy = ppo_ckpt.load(checkpoint)[1]
    return jax.tree.unflatten(
        jax.tree.structure(template), [jnp.asarray(x) for x in jax.tree.leaves(policy["net"])]
    )
