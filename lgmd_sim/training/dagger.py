"""Behaviour cloning with DAgger relabelling (Ross, Gordon and Bagnell 2011): a student
learns the teacher's actions on the states it visits itself, before RL fine-tuning.

Round k collects `steps` environment steps in the student's own training environments:
on each, the teacher labels the state the student is in (its action for that state), and
the environment executes the teacher's action with probability beta_k, else the student's.
The labelled states of every round are kept (the aggregate), and the student is fitted to
all of them. Round 0 is the teacher driving (beta 1), plain behaviour cloning; beta then
falls linearly to 0 by half the rounds, so that the later rounds see the states the
student's own mistakes lead to, which plain cloning never shows it.

The teacher (`Teacher`) is a controller per environment acting on what the student's
environment gives: the Oracle reads the ground truth in ``info``; a privileged policy
(``lgmd-sim train --obs privileged``) gets its observation built from the student's
proprioception and goal and the threat's ground truth in ``info``; ``reactive``
(`AlarmAvoid`) is ReactiveAvoid's manoeuvre triggered by the student's own LGMD alarm. The
first two know what the student's observation may not show (the truth), so a student
can only clone what its features foretell of their decisions
(``docs/experiments/tools/imitation_gap.py`` measures how much); the third decides on nothing the
student does not see, which makes it learnable whole, and bounded by its detector.

Why our own loop and not HumanCompatibleAI's ``imitation``: its last release (1.0.1)
requires gymnasium ~=0.29 and stable-baselines3 ~=2.2.1, below our floors (gymnasium 1.x,
stable-baselines3 2.3+), and no earlier release fits either; its expert must be a
stable-baselines3 policy of the learner's own observation, where the Oracle reads
``info``. The loss and the schedule are imitation's: the negative log-likelihood of the
teacher's action under the student's Gaussian, minus 1e-3 times its entropy.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.controllers.avoid import Avoider, AvoidParams
from lgmd_sim.core.fileio import write_files
from lgmd_sim.policies.config import PolicyConfig

__all__ = ["ENT_WEIGHT", "FIT_BATCH", "FIT_EPOCHS", "FIT_LEARNING_RATE", "STUDENT_ACTIONS",
           "AlarmAvoid", "Labels", "Teacher", "beta", "collect", "critic_only", "fit", "imitate"]

#: Weight of the entropy bonus in the cloning loss (imitation's default).
ENT_WEIGHT = 1e-3


class AlarmAvoid(Avoider):
    """ReactiveAvoid's manoeuvre (`lgmd_sim.controllers.avoid`) on an LGMD features
    observation of one model (`lgmd_sim.envs.wrappers.LGMDFeatures`): triggered by its
    alarm (``lgmd_alarm``), turning away from the busier side of its S-layer grid
    (``lgmd_grid``: the cells of the left half of its columns against those of the right
    half, a middle column in neither). ReactiveAvoid's ``side="halves"`` compares the
    halves of the layer itself, |S| where the grid sums [S]+: the same for models whose S
    is not signed, close for LGMD1's.

    Args:
        grid: the observation's (rows, columns) of cells, row-major; two columns or more.
        **params: the manoeuvre's constants (`AvoidParams`).
    """

    Params = AvoidParams

    def __init__(self, grid: tuple[int, int], **params: Any) -> None:
        if grid[1] < 2:
            raise ValueError(f"AlarmAvoid tells left from right: the grid needs 2 columns "
                             f"or more, got {grid[0]} x {grid[1]}")
        self.grid = grid
        super().__init__(**params)

    def _trigger(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> float | None:
        alarm, cells = np.asarray(obs["lgmd_alarm"]), np.asarray(obs["lgmd_grid"])
        rows, cols = self.grid
        if alarm.size != 1 or cells.size % (rows * cols):
            raise ValueError(f"AlarmAvoid reads one model's features: got {alarm.size} "
                             f"alarms and {cells.size} grid cells for a {rows} x {cols} grid")
        if not alarm[0]:
            return None
        cells, half = cells[-rows * cols:].reshape(rows, cols), cols // 2  # the newest grid
        return float(cells[:, :half].sum() - cells[:, cols - half:].sum())  # > 0: left


class Teacher:
    """One teacher controller per environment: the Oracle (``"oracle"``), `Steer` (its
    inputs without its memory, ``"steer"``), ReactiveAvoid's rule on the student's own
    features (``"reactive"``, `AlarmAvoid`) or a privileged policy (a policy folder
    trained with ``--obs privileged``, or a shipped one's name).

    Args:
        spec: "oracle", "steer", "reactive" or the policy.
        n_envs: environments it labels.
        student: the student's policy configuration: a teacher policy must have trained
            in its environment; "reactive" needs its features (one LGMD model).
    """

    def __init__(self, spec: str, n_envs: int, student: PolicyConfig) -> None:
        from lgmd_sim import controllers

        self.spec = spec
        self._observe: Callable[[Mapping[str, np.ndarray], Mapping[str, Any]],
                                Mapping[str, np.ndarray]] = lambda obs, info: obs
        if spec in ("oracle", "steer"):
            self.controllers = [controllers.make(spec) for _ in range(n_envs)]
        elif spec == "reactive":
            if student.obs != "features":
                raise ValueError("teacher reactive acts on the student's LGMD alarm: it "
                                 f"needs --obs features, not {student.obs}")
            self.controllers = [AlarmAvoid(student.grid) for _ in range(n_envs)]
        else:
            from lgmd_sim.envs.wrappers import PrivilegedObservation

            self.controllers = [controllers.make("policy", path=spec) for _ in range(n_envs)]
            trained = self.controllers[0].policy
            if trained.config.obs != "privileged":
                raise ValueError(f"teacher {spec}: a teacher policy must see privileged "
                                 "observations (lgmd-sim train --obs privileged), not "
                                 f"{trained.config.obs}")
            if trained.config.env_id != student.env_id:
                raise ValueError(f"teacher {spec}: trained in {trained.config.env_id}, not "
                                 f"the student's {student.env_id}")
            keys = list(trained.network.observation_space.spaces)

            def observe(obs: Mapping[str, np.ndarray], info: Mapping[str, Any]
                        ) -> dict[str, np.ndarray]:
                # the student's own keys (an LGMD's features) are not the teacher's
                seen = PrivilegedObservation.observation_of(obs, info)
                return {k: seen[k] for k in keys}

            self._observe = observe

    def reset(self, i: int) -> None:
        """Environment `i` starts a new episode."""
        self.controllers[i].reset()

    def act(self, i: int, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> np.ndarray:
        """The teacher's action in environment `i`, for the student's raw observation
        `obs` there and its ``info``."""
        return np.asarray(self.controllers[i].act(self._observe(obs, info), info), np.float32)


def beta(round_: int, rounds: int) -> float:
    """The share of steps the teacher drives in round `round_` of `rounds`: 1 in round 0,
    then linearly down to 0 at round ``rounds // 2`` and after."""
    half = max(1, rounds // 2)
    return max(0.0, 1.0 - round_ / half)


class Labels:
    """The aggregate: every round's raw observations (per key) and the teacher's actions,
    kept as plain arrays (``save``: an .npz without pickles)."""

    def __init__(self, obs: Mapping[str, np.ndarray] | None = None,
                 actions: np.ndarray | None = None) -> None:
        self.obs = {k: np.asarray(v) for k, v in (obs or {}).items()}
        self.actions = np.zeros((0, 2), np.float32) if actions is None else actions

    def __len__(self) -> int:
        return len(self.actions)

    def extend(self, obs: Mapping[str, np.ndarray], actions: np.ndarray) -> None:
        self.obs = {k: np.concatenate([self.obs[k], v]) if self.obs else v
                    for k, v in obs.items()}
        self.actions = np.concatenate([self.actions, actions])

    def first(self, n: int) -> Labels:
        """The first `n` labels."""
        return Labels({k: v[:n] for k, v in self.obs.items()}, self.actions[:n])

    def save(self, path: Path) -> None:
        arrays = {f"obs.{k}": v for k, v in self.obs.items()} | {"actions": self.actions}
        write_files({path: lambda tmp: np.savez(tmp, **arrays)})

    @classmethod
    def load(cls, path: Path) -> Labels:
        with np.load(path, allow_pickle=False) as f:
            return cls({k[4:]: f[k] for k in f.files if k.startswith("obs.")}, f["actions"])


def collect(venv: Any, reset_infos: Callable[[], Sequence[Mapping[str, Any]]],
            student: Callable[[Mapping[str, np.ndarray]], np.ndarray], teacher: Teacher,
            steps: int, beta_: float, rng: np.random.Generator
            ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Step `venv` (a VecNormalize over the student's environments) for `steps` vector
    steps: per environment and step, the teacher's label for the state the student is in,
    and the teacher's action executed with probability `beta_`, else the student's
    (`student` maps the normalised observations to actions).

    `reset_infos` gives the workers' reset infos (the ground truth of each episode's first
    frame, which a VecEnv's auto-reset keeps there). Returns the raw observations (per
    key, steps x envs rows, step-major), the labels and the executed actions.
    """
    n = venv.num_envs
    norm = venv.reset()
    infos = list(reset_infos())
    for i in range(n):
        teacher.reset(i)
    seen: dict[str, list[np.ndarray]] = {}
    labels, executed = [], []
    for _ in range(steps):
        raw = venv.get_original_obs()
        label = np.stack([teacher.act(i, {k: v[i] for k, v in raw.items()}, infos[i])
                          for i in range(n)])
        drive = np.where((rng.random(n) < beta_)[:, None], label, student(norm))
        for k, v in raw.items():
            seen.setdefault(k, []).append(v.copy())
        labels.append(label)
        executed.append(drive)
        norm, _, dones, infos = venv.step(drive)
        infos = list(infos)
        if dones.any():
            starts = reset_infos()
            for i in np.flatnonzero(dones):
                infos[i] = starts[i]  # the next observation is the new episode's first
                teacher.reset(i)
    return ({k: np.concatenate(v) for k, v in seen.items()}, np.concatenate(labels),
            np.concatenate(executed))


def fit(policy: Any, obs: Mapping[str, np.ndarray], actions: np.ndarray, *, epochs: int,
        batch_size: int, learning_rate: float, seed: int,
        normalize: Callable[[dict[str, np.ndarray]], dict[str, np.ndarray]] = dict) -> float:
    """Fit a stable-baselines3 actor-critic policy's action distribution to `actions` on
    `obs` (raw, per key; `normalize` makes a minibatch what the policy sees, so that no
    normalised copy of the whole aggregate is made) by minibatch Adam on the negative
    log-likelihood minus `ENT_WEIGHT` times the entropy; return the last epoch's mean
    loss."""
    import torch

    optimizer = torch.optim.Adam(policy.parameters(), lr=learning_rate)
    rng = np.random.default_rng(seed)
    target = torch.as_tensor(np.clip(actions, -1.0, 1.0), dtype=torch.float32)
    policy.set_training_mode(True)
    loss_sum = 0.0
    for _ in range(epochs):
        order = rng.permutation(len(actions))
        loss_sum, batches = 0.0, 0
        for start in range(0, len(order), batch_size):
            rows = order[start:start + batch_size]
            batch = {k: torch.as_tensor(v, dtype=torch.float32)
                     for k, v in normalize({k: v[rows] for k, v in obs.items()}).items()}
            _, log_prob, entropy = policy.evaluate_actions(batch, target[rows])
            loss = -log_prob.mean() - ENT_WEIGHT * entropy.mean()
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            loss_sum, batches = loss_sum + float(loss.detach()), batches + 1
        loss_sum /= max(1, batches)
    policy.set_training_mode(False)
    return loss_sum


#: Cloning's epochs over the aggregate after each round (the default of
#: ``dagger_epochs``), minibatch size and Adam's step size (imitation's BC defaults but
#: the epochs: the aggregate grows each round, so a few passes over all of it refit every
#: label).
FIT_EPOCHS, FIT_BATCH, FIT_LEARNING_RATE = 4, 256, 3e-4

#: How the student acts on the steps it drives in a round (``dagger_student``): "sample"
#: draws from its Gaussian, as RL explores; "mean" takes its mean, the action validation
#: and evaluation execute, so the rounds visit the states the deterministic policy
#: reaches (imitation's DAgger samples; a wide Gaussian then drives elsewhere).
STUDENT_ACTIONS = ("sample", "mean")


def imitate(model: Any, venv: Any, reset_infos: Callable[[], Sequence[Mapping[str, Any]]],
            teacher: Teacher, labels: Labels, *, rounds: int, steps: int, first_round: int,
            seed: int, after_round: Callable[[int, float, float], None],
            epochs: int = FIT_EPOCHS, student_actions: str = "sample") -> None:
    """Rounds `first_round` to ``rounds - 1`` of DAgger on `model`'s policy (a
    stable-baselines3 PPO model) in `venv` (its training VecNormalize), ``steps / rounds``
    environment steps each, `labels` the aggregate so far (extended in place), the student
    acting by `student_actions` (`STUDENT_ACTIONS`) and fitted for `epochs` epochs after
    each round. The observation statistics are those after round 0 (the teacher driving)
    in every fit. After each round, `model.num_timesteps` counts its steps and
    ``after_round(round, beta, loss)`` runs (validation, checkpoint, record)."""
    vector_steps = steps // rounds // venv.num_envs  # at least 1: TrainConfig checks
    rng = np.random.default_rng([seed, first_round])
    for k in range(first_round, rounds):
        venv.training = k == 0  # the normalisation learns from round 0 only

        def student(norm: Mapping[str, np.ndarray]) -> np.ndarray:
            return model.predict(norm, deterministic=student_actions == "mean")[0]

        obs, actions, _ = collect(venv, reset_infos, student, teacher, vector_steps,
                                  beta(k, rounds), rng)
        labels.extend(obs, actions)
        loss = fit(model.policy, labels.obs, labels.actions, epochs=epochs,
                   batch_size=FIT_BATCH, learning_rate=FIT_LEARNING_RATE, seed=seed + k,
                   normalize=venv.normalize_obs)
        model.num_timesteps += vector_steps * venv.num_envs
        after_round(k, beta(k, rounds), loss)
    venv.training = True


@contextmanager
def critic_only(policy: Any) -> Iterator[None]:
    """Within it, only the value function of `policy` (a stable-baselines3 actor-critic
    policy) learns: every other parameter, a features extractor it shares with the actor
    included, is frozen (``requires_grad`` False, so PPO's optimiser skips it).

    Why: `fit` trains the action distribution alone, so after DAgger the value function
    is still the initial one. PPO's advantages are then noise, normalised to unit scale
    per minibatch, and its first updates move a cloned policy far from what it learnt
    (docs/experiments/training-runs.md: the approximate KL per update of the runs that
    unlearnt their task). Warming the critic up on the student's own rollouts first gives PPO
    advantages that mean something.
    """
    critic = [policy.value_net, policy.mlp_extractor.value_net]
    if not policy.share_features_extractor:
        critic.append(policy.vf_features_extractor)
    learns = {id(p) for net in critic for p in net.parameters()}
    before = [(p, p.requires_grad) for p in policy.parameters()]
    for p, _ in before:
        p.requires_grad_(id(p) in learns)
    try:
        yield
    finally:
        for p, flag in before:
            p.requires_grad_(flag)
