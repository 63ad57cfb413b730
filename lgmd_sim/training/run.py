"""`lgmd-sim train`: one training run in a folder, from its options to its policy.

The run, in order: check every option (`lgmd_sim.training.config.TrainConfig`: a bad one
is one line, before anything starts); build the environments and measure the bare
VecEnv's steps per second, which also checks that rewards are finite; then train with
stable-baselines3, phase by phase (`lgmd_sim.training.phases`: DAgger, the value warm-up,
RL through the curriculum), validating on fixed held-out seeds and writing checkpoints as
it goes; at the end write the policy folders, the learning curve, the run's record and its
summary (`lgmd_sim.training.summary`).

Layout of ``DIR``:

- ``run.json`` (`lgmd_sim.core.runs.RunFolder`): the configuration, the machine, and per
  session (the first run and each resume) the exact command, wall time, versions,
  environment seeds, steps and throughput;
- ``policy.npz``, ``policy.json``: the final policy (a policy folder, see
  `lgmd_sim.policies.folder`); ``best/``: the one with the best validation score;
- ``checkpoints/``: what ``--resume DIR`` continues from;
- ``logs/session-N/``: stable-baselines3's CSV log (``progress.csv``) and TensorBoard
  events; ``learning_curve.png`` is drawn from them; ``summary.md``.

Seeds: the training environments reset with seeds from ``--seed`` (environment i of
session s with ``seed + i + the environments of the sessions before``; later episodes
continue each environment's generator), below `VALIDATION_SEED`; validation uses seeds
``VALIDATION_SEED`` to ``VALIDATION_SEED + eval_seeds - 1``; the benchmark and
``lgmd-sim bench closed-loop --policies`` use seeds from 1000: the three never share an
episode.
"""

from __future__ import annotations

import copy
import functools
import math
import platform
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from lgmd_sim import __version__
from lgmd_sim.core.extras import require
from lgmd_sim.core.fileio import read_json, write_text_atomic
from lgmd_sim.core.params import FieldError
from lgmd_sim.core.runs import RECORD, Maybe, RunFolder, RunResult, read_record
from lgmd_sim.policies.config import PolicyConfig
from lgmd_sim.policies.folder import ALGOS
from lgmd_sim.training.config import VALIDATION_SEED, TrainConfig
from lgmd_sim.training.summary import run_record, summary_markdown, trained, validation_rows

__all__ = ["RESUMABLE", "TrainConfig", "resumable", "train"]

#: Options a resumed run may change; the others must be as recorded.
RESUMABLE = ("steps", "envs", "hp", "value_warmup")
#: What a checkpoint's state.json may name besides its step count (counts, all of them).
_STATE_KEYS = ("stage", "imitation_round", "labels", "critic_until")


def _versions() -> dict[str, str]:
    # from the installed metadata: importing mujoco here would fix its GL backend before
    # lgmd_sim.world.gl chooses it
    from importlib.metadata import version

    return {"lgmd-sim": __version__, "python": platform.python_version(),
            **{name: version(name) for name in ("stable-baselines3", "torch", "gymnasium",
                                                "mujoco", "numpy")}}


def resumable(out: str | Path) -> dict[str, Any]:
    """The record of the training run in `out` (its options under "config"), which must
    hold a checkpoint to resume from; ValueError naming what is missing, or the record
    where it is not a training run's (`lgmd_sim.training.summary.run_record`)."""
    if not (Path(out) / RECORD).is_file():
        raise ValueError(f"{out}: no training run there to resume (no run.json)")
    record = run_record(out)
    if not (Path(out) / "checkpoints" / "state.json").is_file():
        raise ValueError(f"{out}: the run has no checkpoint to resume from")
    return record


def train(config: TrainConfig, out: str | Path, *, resume: bool = False,
          progress: bool | None = None, command: str = "") -> RunResult:
    """Train the policy of `config` in folder `out`, or (with `resume`) continue the run
    there from its last checkpoint up to ``config.steps`` (only `RESUMABLE` options may
    differ from the run's); return its validation rows (final, best).

    Raises:
        ValueError: a folder holding something else, a run without a checkpoint, a step
            budget already reached, seeds that would reach the validation seeds, an
            environment whose reward is not finite, a hyperparameter value
            stable-baselines3 refuses (one line each, leaving no run behind).
    """
    require("stable_baselines3", "rl")
    require("tensorboard", "rl")
    from lgmd_sim.training import algos

    out = Path(out)
    checkpoints = out / "checkpoints"
    recorded = resumable(out) if resume else None
    # where the run continues: its step count, curriculum stage, DAgger round and labels
    resumed = _checkpoint_state(checkpoints) if resume else {}
    if resume and config.steps <= resumed["num_timesteps"]:
        raise FieldError("steps", f"must be more than the {resumed['num_timesteps']} steps "
                         f"the run has made, got {config.steps}")
    curriculum = config.stages
    stage = resumed.get("stage", 0)
    if curriculum and resume and recorded.get("curriculum") != curriculum.as_json():
        raise ValueError(f"curriculum {config.curriculum}: its stages changed since the run "
                         "started")
    sessions = recorded["sessions"] if recorded else []
    first_seed = config.seed + sum(s["env_seeds"][1] for s in sessions)
    # each stage still to come builds its environments with fresh seeds
    last_seed = first_seed + config.envs * (1 + len(curriculum.stages) - stage
                                            if curriculum else 1) - 1
    if last_seed >= VALIDATION_SEED:
        raise ValueError(f"training seeds {first_seed} to {last_seed} would reach the "
                         f"validation seeds (from {VALIDATION_SEED}): use a lower --seed or "
                         "fewer --envs")
    kwargs = algos.hyperparameters(config.algo, config.obs,
                                   algos.parse_overrides(config.hp, config.algo))
    return _train(out, config, kwargs, first_seed, resumed, progress, command)


def _train(out: Path, config: TrainConfig, kwargs: dict[str, Any], first_seed: int,
           resumed: dict[str, Any], progress_bar: bool | None, command: str
           ) -> RunResult:
    # `resumed` is the checkpoint's state.json, empty for a new run
    import torch
    from stable_baselines3.common.logger import configure

    from lgmd_sim import policies
    from lgmd_sim.training import algos, callbacks, curve, phases
    from lgmd_sim.training.envs import bare_speed, make_vec_env, normalized

    torch.set_num_threads(1)  # the environment workers have the other cores
    checkpoints = out / "checkpoints"
    policy = config.policy()
    folder = RunFolder(out, config.as_json(), command, resume=bool(resumed),
                       what="training run",
                       resume_hint=f"add --resume {out} to continue it",
                       changeable=RESUMABLE, start=False)
    curriculum, stage = config.stages, resumed.get("stage", 0)
    live = phases.TrainingEnvs(policy, config, kwargs, stage)
    validation = None
    try:
        bare = bare_speed(live.envs, policy.env_id)
        earlier = len(folder.sessions) - 1
        if earlier:
            live.venv, model = _load_checkpoint(checkpoints, live.envs.venv, policy.algo,
                                                algos.parse_overrides(config.hp, policy.algo))
            model.set_random_seed(config.seed + earlier)
        else:
            live.venv = normalized(live.envs.venv, policy.obs, policy.algo, kwargs)
            model = algos.make_model(policy.algo, live.venv, kwargs, config.seed)
        folder.start()  # only now: hyperparameters the library refuses leave no run behind
        folder.session.update(versions=_versions(), env_seeds=[first_seed, config.envs])
        folder.note(policy=policy.to_json(), hyperparameters=kwargs, seeds={
            "training": "from the first of each session's env_seeds",
            "validation": [VALIDATION_SEED, config.eval_seeds], "test": "from 1000"},
            **({"curriculum": curriculum.as_json()} if curriculum else {}))
        live.venv.seed(first_seed)  # environment i: first_seed + i, at the reset learn() makes
        model.set_logger(configure(str(out / "logs" / f"session-{earlier}"),
                                   ["csv", "tensorboard"]))
        steps_from = model.num_timesteps

        validation = make_vec_env(policy, config.envs)  # the environment's own reward
        progress = callbacks.Progress(config.steps, progress_bar)
        best = _Best(out / "best", policy, command)
        validate = _validation(validation, config, policy, model, progress, best)
        stages = callbacks.StageCallback(curriculum, stage) if curriculum else None
        # what checkpoints name, besides the step count: DAgger's round and labels
        # (`phases.imitate` keeps them), the step the value warm-up ends at (0: not
        # started), the curriculum's stage
        resume_at = {key: resumed.get(key, 0) for key in ("imitation_round", "labels",
                                                          "critic_until")
                     } if config.teacher else {}
        checkpoint = callbacks.Checkpoint(checkpoints, config.checkpoint_every,
                                          functools.partial(_state, resume_at, stages))
        imitation_s = phases.imitate(config, model, live.venv, live.envs, checkpoints,
                                     validate, checkpoint, folder, resume_at
                                     ) if config.teacher else 0.0
        # the RL phase's own time: validations and checkpoints of the rounds are not in it
        rl_from, rl_other_s = model.num_timesteps, validate.seconds + checkpoint.seconds
        stats = callbacks.EpisodeStats()
        learn_s = phases.warm_up_value(config, model, resume_at,
                                       [progress, stats, validate, checkpoint], folder)
        learn_s += phases.reinforce(config, model, live, stages, [progress, stats, validate],
                                    checkpoint, folder)
    finally:
        live.envs.close()
        if validation is not None:
            validation.close()

    steps = model.num_timesteps - rl_from
    training_s = learn_s - (validate.seconds + checkpoint.seconds - rl_other_s)
    folder.session.update(
        steps=[steps_from, model.num_timesteps], validation_s=round(validate.seconds),
        imitation_s=round(imitation_s), throughput={
            "bare_vec_env_steps_per_s": round(bare, 1),
            "training_steps_per_s": round(steps / training_s, 1),
            "ratio": round(steps / training_s / bare, 3)})
    policies.save(out, model, policy, policies.Normalizer.of(live.venv),
                  steps=model.num_timesteps, command=command,
                  validation=best.last, version=__version__)
    curve.learning_curve(out, f"{out.name}: {trained(config.as_json())}")
    folder.finish()
    write_text_atomic(out / "summary.md", summary_markdown(out))
    files = ["policy.npz", "policy.json", "best/", "learning_curve.png", "summary.md",
             "run.json", "logs/", "checkpoints/"]
    return RunResult(out, validation_rows(out), files)


def _validation(validation: Any, config: TrainConfig, policy: PolicyConfig, model: Any,
                progress: Any, best: _Best) -> Any:
    """The validation callback: the environments `validation` (the task's own reward) on
    the held-out seeds every ``eval_every`` steps, normalised with the training
    statistics of the moment (frozen), the scores shown by `progress` and offered to
    `best`."""
    from stable_baselines3.common.vec_env import VecNormalize

    from lgmd_sim.training import callbacks
    from lgmd_sim.training.envs import normalized_keys

    val_norm = VecNormalize(validation.venv, training=False, norm_reward=False,
                            norm_obs_keys=normalized_keys(validation.venv, policy.obs))
    validation.venv = val_norm

    def sync() -> None:
        val_norm.obs_rms = copy.deepcopy(model.get_vec_normalize_env().obs_rms)

    def on_scores(step: int, scores: dict[str, float]) -> None:
        progress.show({"val success": scores["success_rate"],
                       "collisions": scores["collision_rate"]})
        best.offer(model, step, scores)

    return callbacks.Validation(
        validation, range(VALIDATION_SEED, VALIDATION_SEED + config.eval_seeds),
        config.eval_every, sync, on_scores)


def _state(resume_at: dict[str, Any], stages: Any) -> dict[str, Any]:
    """What a checkpoint's state.json names besides the step count (`_STATE_KEYS`)."""
    # a checkpoint written as a stage is passed resumes at the next one
    return resume_at | ({"stage": stages.stage + stages.ready} if stages else {})


def _load_checkpoint(folder: Path, venv: Any, algo: str, overrides: Mapping[str, Any]
                     ) -> tuple[Any, Any]:
    """The VecNormalize (around `venv`) and the model of the checkpoint in `folder`, with
    the hyperparameter `overrides` (a resumed run may add some) over the saved ones."""
    from stable_baselines3.common.vec_env import VecNormalize

    cls = getattr(require("stable_baselines3", "rl"), ALGOS[algo])
    try:
        normalized = VecNormalize.load(str(folder / "vecnormalize.pkl"), venv)
        # the network's shape is the checkpoint's: TrainConfig refuses a new one
        model = cls.load(folder / "model.zip", env=normalized, device="cpu",
                         **{k: v for k, v in overrides.items() if k != "policy_kwargs"})
        normalized.training = True  # saved frozen between DAgger rounds
    except (AssertionError, ValueError) as exc:  # SB3 asserts that the spaces match
        raise ValueError(f"the checkpoint in {folder} does not fit the environment as it is "
                         f"now (it changed since the run started?): {exc}") from None
    if (folder / "replay_buffer.pkl").is_file():
        model.load_replay_buffer(folder / "replay_buffer.pkl")
    return normalized, model


def _checkpoint_state(folder: Path) -> dict[str, Any]:
    """The checkpoint's step count ("num_timesteps") and what `_train`'s ``state()``
    adds (the curriculum's stage, DAgger's round and labels, the value warm-up's end);
    ValueError naming state.json where it holds anything else."""
    file = folder / "state.json"
    state = read_record(file, {"num_timesteps": int, **{k: Maybe(int) for k in _STATE_KEYS}},
                        "the run cannot be resumed from it")
    negative = [k for k in ("num_timesteps", *_STATE_KEYS) if state.get(k, 0) < 0]
    if negative:
        raise ValueError(f"{file}: {negative[0]} is {state[negative[0]]}, not a count >= 0: "
                         "the run cannot be resumed from it")
    return state


class _Best:
    """Keeps ``folder`` (a policy folder) at the validation's best score so far: success
    rate minus collision rate, then return; a resumed run starts from the saved best."""

    def __init__(self, folder: Path, config: PolicyConfig, command: str) -> None:
        self.folder, self.config, self.command = folder, config, command
        self.last: dict[str, Any] | None = None
        try:
            saved = read_json(folder / "policy.json")["trained"]["validation"]
            self.score = self._score(saved["scores"])
        except (ValueError, KeyError, TypeError):  # none usable: the next validation's is best
            self.score = (-math.inf, -math.inf)

    @staticmethod
    def _score(scores: Mapping[str, float]) -> tuple[float, float]:
        return (scores["success_rate"] - scores["collision_rate"], scores["mean_reward"])

    def offer(self, model: Any, step: int, scores: dict[str, float]) -> None:
        from lgmd_sim import policies

        self.last = {"step": step, "scores": scores}
        if self._score(scores) > self.score:
            self.score = self._score(scores)
            policies.save(self.folder, model, self.config,
                          policies.Normalizer.of(model.get_vec_normalize_env()),
                          steps=step, command=self.command, validation=self.last,
                          version=__version__)
