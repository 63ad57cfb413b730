"""The phases of a training session, in the order `lgmd_sim.training.run` runs them on the
model and environments it set up: DAgger's rounds, with a teacher (`imitate`); the value
function's warm-up after them (`warm_up_value`); then reinforcement learning, PPO or SAC,
up to the step budget (`reinforce`), through the curriculum's stages where the run has
one: a stage passed is recorded and its environments give way to the next stage's
(`TrainingEnvs`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lgmd_sim.core.runs import RunFolder
from lgmd_sim.policies.config import PolicyConfig
from lgmd_sim.training.config import TrainConfig

if TYPE_CHECKING:
    from lgmd_sim.training.callbacks import StageCallback

__all__ = ["TrainingEnvs", "imitate", "reinforce", "warm_up_value"]


class TrainingEnvs:
    """The environments a session trains on: ``envs`` (`lgmd_sim.training.envs.VecEnvs`,
    those of curriculum stage `stage`) and ``venv``, the VecNormalize around them that the
    model steps (set by the caller with the model: a new one, or a checkpoint's). A stage
    passed replaces both (`next_stage`); the caller closes ``envs``, whichever they are
    then.
    """

    def __init__(self, policy: PolicyConfig, config: TrainConfig, kwargs: Mapping[str, Any],
                 stage: int) -> None:
        from lgmd_sim.training.envs import make_vec_env

        self.policy, self.config, self.kwargs = policy, config, kwargs
        self.envs = make_vec_env(policy, config.envs, config.overrides(stage))
        self.venv: Any = None

    def next_stage(self, stage: int, session: dict[str, Any]) -> None:
        """Close the environments of the stage passed and make those of `stage`, their
        normalisation starting from the last stage's statistics, seeded from the seeds
        no environment of the run had (`session`'s ``env_seeds`` follows)."""
        from lgmd_sim.training.envs import make_vec_env, normalized

        policy, config = self.policy, self.config
        self.envs.close()
        self.envs = make_vec_env(policy, config.envs, config.overrides(stage))
        self.venv = normalized(self.envs.venv, policy.obs, policy.algo, self.kwargs,
                               like=self.venv)
        seeds = session["env_seeds"]
        self.venv.seed(seeds[0] + seeds[1])
        session["env_seeds"] = [seeds[0], seeds[1] + config.envs]


def imitate(config: TrainConfig, model: Any, venv: Any, envs: Any, checkpoints: Path,
            validate: Any, checkpoint: Any, folder: RunFolder,
            resume_at: dict[str, Any]) -> float:
    """The DAgger rounds of `config` not yet done (`resume_at`, what checkpoints name,
    holds the next round and how many labels were kept), each validated, checkpointed with
    the aggregate (``dagger.npz``) and recorded in the session's ``imitation``; `resume_at`
    follows. Return the seconds they took, validation and checkpoints included."""
    from lgmd_sim.training import dagger

    first = resume_at["imitation_round"]
    if first >= config.dagger_rounds:
        return 0.0
    start = time.perf_counter()
    # a run stopped between saving the aggregate and naming it in state.json: the
    # labels beyond the count state.json names are a round that did not complete
    labels = (dagger.Labels.load(checkpoints / "dagger.npz").first(resume_at["labels"])
              if first else dagger.Labels())
    teacher = dagger.Teacher(config.teacher, config.envs, config.policy())

    def after_round(k: int, beta: float, loss: float) -> None:
        for key, value in (("round", k), ("beta", beta), ("bc_loss", loss),
                           ("labels", len(labels))):
            model.logger.record(f"imitation/{key}", value)
        validate.run_now(model)  # logs and dumps at the step count
        checkpoints.mkdir(parents=True, exist_ok=True)
        labels.save(checkpoints / "dagger.npz")
        resume_at.update(imitation_round=k + 1, labels=len(labels))
        checkpoint.run_now(model)  # state.json last: the round is complete once it names it
        folder.session.setdefault("imitation", []).append(
            {"round": k, "beta": beta, "steps": model.num_timesteps, "labels": len(labels),
             "bc_loss": loss, **{f"val_{n}": validate.scores[f"{n}_rate"]
                                 for n in ("success", "collision")}})
        folder.note()

    dagger.imitate(model, venv, lambda: envs.base.reset_infos, teacher, labels,
                   rounds=config.dagger_rounds, steps=config.imitation_steps,
                   first_round=first, seed=config.seed, after_round=after_round,
                   epochs=config.dagger_epochs, student_actions=config.dagger_student)
    return time.perf_counter() - start


def warm_up_value(config: TrainConfig, model: Any, resume_at: dict[str, Any],
                  callback: Sequence[Any], folder: RunFolder) -> float:
    """After the DAgger rounds, PPO's updates of the value function alone
    (`lgmd_sim.training.dagger.critic_only`) for ``config.value_warmup`` steps, once:
    `resume_at` names the step it ends at (0: not started). Recorded in the session's
    ``value_warmup``; return the seconds its learning took."""
    if config.value_warmup and not resume_at["critic_until"]:
        resume_at["critic_until"] = model.num_timesteps + config.value_warmup
    if not (config.teacher and model.num_timesteps < resume_at["critic_until"]):
        return 0.0
    from lgmd_sim.training.dagger import critic_only

    learn_start = time.perf_counter()
    # the update counter tells the warm-up's updates apart in the logs
    steps, updates = [model.num_timesteps], [model._n_updates]
    with critic_only(model.policy):
        model.learn(total_timesteps=resume_at["critic_until"] - model.num_timesteps,
                    reset_num_timesteps=False, callback=list(callback))
    seconds = time.perf_counter() - learn_start
    folder.session["value_warmup"] = {"steps": [*steps, model.num_timesteps],
                                      "n_updates": [*updates, model._n_updates]}
    return seconds


def reinforce(config: TrainConfig, model: Any, live: TrainingEnvs,
              stages: StageCallback | None, watch: Sequence[Any], checkpoint: Any,
              folder: RunFolder) -> float:
    """Reinforcement learning up to ``config.steps``, with the callbacks `watch` and then
    `checkpoint`: at once, or stage by stage of the curriculum (`stages`, between them),
    each stage recorded in the session's ``stages``, and a stage passed moving the model
    onto the next stage's environments (`live`). Return the seconds learning took."""
    learn_s = 0.0
    while True:
        learn_start, stage_from = time.perf_counter(), model.num_timesteps
        model.learn(total_timesteps=config.steps - model.num_timesteps,
                    reset_num_timesteps=False,
                    callback=[*watch, *([stages] if stages else []), checkpoint])
        learn_s += time.perf_counter() - learn_start
        if stages is None:
            break
        folder.session.setdefault("stages", []).append(
            {"stage": stages.stage, "overrides": config.stage_overrides(stages.stage),
             "steps": [stage_from, model.num_timesteps], "episodes": stages.episodes,
             "success_rate": stages.success_rate(), "passed": stages.ready})
        if not stages.ready or model.num_timesteps >= config.steps:
            break
        stages.advance()
        live.next_stage(stages.stage, folder.session)
        folder.note()  # the stage passed, on record before the next starts
        model.set_env(live.venv)  # its next learn() resets the new environments
    return learn_s
