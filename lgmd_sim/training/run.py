"""`lgmd-sim train`: one training run in a folder, from its options to its policy.

The run, in order: check every option (a bad one is one line, before anything starts);
build the environments and measure the bare VecEnv's steps per second, which also checks
that rewards are finite; then train with stable-baselines3, validating on fixed held-out
seeds and writing checkpoints as it goes; at the end write the policy folders, the
learning curve, the run's record and its summary (`lgmd_sim.training.summary`).

Layout of ``DIR``:

- ``run.json`` (`lgmd_sim.runs.RunFolder`): the configuration, the machine, and per
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
``lgmd-sim eval`` use seeds from 1000: the three never share an episode.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import json
import math
import platform
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lgmd_sim import __version__, options
from lgmd_sim.extras import require
from lgmd_sim.fileio import read_json, write_text_atomic
from lgmd_sim.policies.config import PolicyConfig
from lgmd_sim.policies.folder import ALGOS, OBS
from lgmd_sim.runs import RECORD, Maybe, RunFolder, RunResult, read_record
from lgmd_sim.training.dagger import FIT_EPOCHS, STUDENT_ACTIONS
from lgmd_sim.training.summary import run_record, summary_markdown, trained, validation_rows

if TYPE_CHECKING:
    from lgmd_sim.training.curriculum import Curriculum

__all__ = ["RESUMABLE", "VALIDATION_SEED", "TrainConfig", "resumable", "train"]

#: The first validation seed; training seeds stay below it, test seeds start at 1000.
VALIDATION_SEED = 900
#: Options a resumed run may change; the others must be as recorded.
RESUMABLE = ("steps", "envs", "hp", "value_warmup")
#: What a checkpoint's state.json may name besides its step count (counts, all of them).
_STATE_KEYS = ("stage", "imitation_round", "labels", "critic_until")


@dataclass(frozen=True)
class TrainConfig:
    """What a training run trains, checked when it is made (a bad value raises a
    one-line ValueError naming it).

    Attributes:
        algo: a key of `lgmd_sim.policies.folder.ALGOS` ("ppo", "sac").
        env: the Gymnasium id of the environment.
        obs: "features" (an LGMD model's signals with the proprioception and goal),
            "pixels" (small stacked grey frames) or "privileged" (the threat's ground
            truth that the Oracle reads, with the proprioception and goal).
        model, preset: the LGMD model of "features", MODEL or MODEL/PRESET (with front
            ends), and its preset (None: the model's default); both None otherwise.
        grid: (rows, columns) of the S-layer grid of "features"
            (`lgmd_sim.envs.wrappers.LGMDFeatures`).
        grid_history: how many of the last grids "features" observes (1: the present).
        resolution: the frame size the environment renders.
        jitter: the jitter level of the training episodes.
        steps: environment steps in all, over every environment and session.
        envs: environments stepped in parallel (worker processes).
        seed: seed of the model and of the first training environment.
        eval_every, eval_seeds: validate every N steps on this many held-out seeds (from
            `VALIDATION_SEED`).
        checkpoint_every: write a checkpoint every N steps.
        hp: hyperparameter overrides, each "KEY=VALUE" (`lgmd_sim.training.algos`); a
            resumed run may add some (a later one wins), not ``policy_kwargs`` (the
            checkpoint's network has its shape).
        reward: reward parameters of the training environments, each "KEY=VALUE"
            (`lgmd_sim.training.envs.parse_reward`); validation keeps the environment's.
        curriculum: a curriculum (`lgmd_sim.training.curriculum`: a built-in name or a
            TOML file) the training environments go through before the task itself;
            None: the task from the start.
        teacher: "oracle", "steer" (the Oracle's inputs without its memory,
            `lgmd_sim.controllers.steer`), "reactive" (ReactiveAvoid's rule on the
            policy's own LGMD features) or a privileged policy (a folder or a shipped
            name) the policy first learns from by DAgger (`lgmd_sim.training.dagger`),
            before RL; None: RL from the start. PPO only.
        imitation_steps: environment steps of the DAgger rounds (part of `steps`).
        dagger_rounds: DAgger rounds, each ``imitation_steps / dagger_rounds`` steps.
        dagger_epochs: cloning's epochs over the labels kept after each round.
        dagger_student: how the student acts on the steps it drives in the rounds,
            "sample" or "mean" (`lgmd_sim.training.dagger.STUDENT_ACTIONS`).
        value_warmup: environment steps of PPO after the DAgger rounds in which only the
            value function learns (`lgmd_sim.training.dagger.critic_only`), part of
            `steps`; 0: none. Given when resuming a run past its DAgger rounds that had
            none, the warm-up starts there; it runs once.
    """

    algo: str = "ppo"
    env: str = "lgmd_sim/RoughTerrainObstacles-v0"
    obs: str = "features"
    model: str | None = "feedback"
    preset: str | None = None
    grid: tuple[int, int] = PolicyConfig.grid
    grid_history: int = PolicyConfig.grid_history
    resolution: str | tuple[int, int] = "rl"
    jitter: float = 1.0
    steps: int = 300_000
    envs: int = 2
    seed: int = 0
    eval_every: int = 25_000
    eval_seeds: int = 10
    checkpoint_every: int = 25_000
    hp: tuple[str, ...] = ()
    reward: tuple[str, ...] = ()
    curriculum: str | None = None
    teacher: str | None = None
    imitation_steps: int = 100_000
    dagger_rounds: int = 10
    dagger_epochs: int = FIT_EPOCHS
    dagger_student: str = "sample"
    value_warmup: int = 0

    def __post_init__(self) -> None:
        import gymnasium as gym

        from lgmd_sim import models
        from lgmd_sim.training import algos
        from lgmd_sim.training.envs import parse_reward

        # options of the wrong type (a hand-edited run.json being resumed brings them too)
        for key in ("algo", "obs", "env"):
            if not isinstance(getattr(self, key), str):
                raise ValueError(f"--{key} must be a string, got {getattr(self, key)!r}")
        for key in ("hp", "reward"):
            items = getattr(self, key)
            if not (isinstance(items, list | tuple) and all(isinstance(v, str) for v in items)):
                raise ValueError(f"--{key} must be a list of KEY=VALUE strings, got {items!r}")
        if self.algo not in ALGOS:
            raise ValueError(f"unknown algorithm {self.algo!r}; available: {', '.join(ALGOS)}")
        if self.obs not in OBS:
            raise ValueError(f"unknown observation {self.obs!r}; available: {', '.join(OBS)}")
        try:
            gym.spec(self.env)
        except gym.error.Error:
            raise ValueError(f"unknown environment id {self.env!r} (lgmd-sim envs lists "
                             "them)") from None
        if self.obs == "features":
            model, preset = models.parse_spec(
                str(self.model) if self.preset is None else f"{self.model}/{self.preset}")
        else:
            model = preset = None
        grid = tuple(self.grid) if isinstance(self.grid, list | tuple) else ()
        if not (len(grid) == 2 and all(isinstance(v, int) and not isinstance(v, bool)
                                       and v >= 1 for v in grid)):
            raise ValueError(f"--grid must be rows x columns of positive integers, got "
                             f"{self.grid!r}")
        if self.obs != "features" and grid != PolicyConfig.grid:
            raise ValueError(f"--grid is the S-layer grid of --obs features, not {self.obs}")
        object.__setattr__(self, "grid", grid)
        if not (isinstance(self.grid_history, int) and not isinstance(self.grid_history, bool)
                and self.grid_history >= 1):
            raise ValueError(f"--grid-history must be a positive integer, got "
                             f"{self.grid_history!r}")
        if self.obs != "features" and self.grid_history != PolicyConfig.grid_history:
            raise ValueError(f"--grid-history is of --obs features, not {self.obs}")
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "preset", preset)
        object.__setattr__(self, "resolution", options.resolution(self.resolution))
        for key in ("steps", "envs", "eval_every", "checkpoint_every", "eval_seeds"):
            options.check_positive(getattr(self, key), f"--{key.replace('_', '-')}",
                                   integer=True)
        if self.eval_seeds > 1000 - VALIDATION_SEED:
            raise ValueError(f"--eval-seeds must be at most {1000 - VALIDATION_SEED} "
                             f"(validation seeds are {VALIDATION_SEED} to 999), got "
                             f"{self.eval_seeds}")
        options.check_seed(self.seed, "--seed")
        options.check_jitter([self.jitter])
        object.__setattr__(self, "hp", tuple(self.hp))
        algos.parse_overrides(self.hp, self.algo)
        object.__setattr__(self, "reward", tuple(self.reward))
        parse_reward(self.reward)
        self.stages  # noqa: B018  (loads the curriculum once: a bad one is one line now)
        for key in ("imitation_steps", "dagger_rounds", "dagger_epochs"):
            options.check_positive(getattr(self, key), f"--{key.replace('_', '-')}",
                                   integer=True)
        if self.dagger_student not in STUDENT_ACTIONS:
            raise ValueError(f"--dagger-student must be one of {', '.join(STUDENT_ACTIONS)}, "
                             f"got {self.dagger_student!r}")
        if not (isinstance(self.value_warmup, int) and not isinstance(self.value_warmup, bool)
                and self.value_warmup >= 0):
            raise ValueError(f"--value-warmup must be a non-negative integer, got "
                             f"{self.value_warmup!r}")
        if self.value_warmup and self.teacher is None:
            raise ValueError("--value-warmup warms the value function up after DAgger: it "
                             "needs --teacher")
        if self.teacher is not None:
            from lgmd_sim.training.dagger import Teacher

            if self.algo != "ppo":
                raise ValueError(f"--teacher needs --algo ppo (its policy is fitted to the "
                                 f"teacher's actions), not {self.algo}")
            if self.imitation_steps + self.value_warmup >= self.steps:
                warmup = f" and --value-warmup {self.value_warmup}" if self.value_warmup else ""
                raise ValueError(f"--imitation-steps {self.imitation_steps}{warmup} must be "
                                 f"fewer than --steps {self.steps} (RL fine-tuning takes the "
                                 "rest)")
            if self.imitation_steps < self.dagger_rounds * self.envs:
                raise ValueError(f"--imitation-steps {self.imitation_steps} must be at least "
                                 f"--dagger-rounds x --envs ({self.dagger_rounds * self.envs}): "
                                 "a step per environment and round")
            Teacher(self.teacher, 1, self.policy())  # loads: a bad teacher is one line now

    def policy(self) -> PolicyConfig:
        """The configuration of the policy it trains."""
        return PolicyConfig(self.algo, self.obs, self.env, self.resolution,
                            float(self.jitter), self.model, self.preset, grid=self.grid,
                            grid_history=self.grid_history)

    def as_json(self) -> dict[str, Any]:
        """The configuration as the run folder records it."""
        return json.loads(json.dumps(dataclasses.asdict(self)))

    @functools.cached_property
    def stages(self) -> Curriculum | None:
        """The curriculum's stages (read once: a file changed during the run changes
        nothing), or None without one."""
        from lgmd_sim.training.curriculum import load

        return None if self.curriculum is None else load(self.curriculum, self.env)

    def stage_overrides(self, stage: int) -> dict[str, Any]:
        """The environment parameters of curriculum stage `stage` (none past the last)."""
        curriculum = self.stages
        return (dict(curriculum.stages[stage].overrides)
                if curriculum and stage < len(curriculum.stages) else {})

    def overrides(self, stage: int) -> dict[str, Any]:
        """The training environments' parameters at curriculum stage `stage`, the reward
        shaping included."""
        from lgmd_sim.training.envs import parse_reward

        return {**parse_reward(self.reward), **self.stage_overrides(stage)}


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
        raise ValueError(f"--resume {out}: no training run there (no run.json)")
    record = run_record(out)
    if not (Path(out) / "checkpoints" / "state.json").is_file():
        raise ValueError(f"--resume {out}: the run has no checkpoint to resume from")
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
        raise ValueError(f"--steps {config.steps}: the run is at "
                         f"{resumed['num_timesteps']} steps already")
    curriculum = config.stages
    stage = resumed.get("stage", 0)
    if curriculum and resume and recorded.get("curriculum") != curriculum.as_json():
        raise ValueError(f"--curriculum {config.curriculum}: its stages changed since the run "
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
    from stable_baselines3.common.vec_env import VecNormalize

    from lgmd_sim import policies
    from lgmd_sim.training import algos, callbacks, curve
    from lgmd_sim.training.envs import bare_speed, make_vec_env, normalized, normalized_keys

    torch.set_num_threads(1)  # the environment workers have the other cores
    checkpoints = out / "checkpoints"
    policy = config.policy()
    folder = RunFolder(out, config.as_json(), command, resume=bool(resumed),
                       what="training run",
                       resume_hint=f"add --resume {out} to continue it",
                       changeable=RESUMABLE, start=False,
                       # a run recorded before an option existed ran at its default
                       defaults={f.name: f.default for f in dataclasses.fields(TrainConfig)})
    curriculum, stage = config.stages, resumed.get("stage", 0)
    envs = make_vec_env(policy, config.envs, config.overrides(stage))
    validation = None
    try:
        bare = bare_speed(envs, policy.env_id)
        earlier = len(folder.sessions) - 1
        if earlier:
            venv, model = _load_checkpoint(checkpoints, envs.venv, policy.algo,
                                           algos.parse_overrides(config.hp, policy.algo))
            model.set_random_seed(config.seed + earlier)
        else:
            venv = normalized(envs.venv, policy.obs, policy.algo, kwargs)
            model = algos.make_model(policy.algo, venv, kwargs, config.seed)
        folder.start()  # only now: hyperparameters the library refuses leave no run behind
        folder.session.update(versions=_versions(), env_seeds=[first_seed, config.envs])
        folder.note(policy=policy.to_json(), hyperparameters=kwargs, seeds={
            "training": "from the first of each session's env_seeds",
            "validation": [VALIDATION_SEED, config.eval_seeds], "test": "from 1000"},
            **({"curriculum": curriculum.as_json()} if curriculum else {}))
        venv.seed(first_seed)  # environment i: first_seed + i, at the reset learn() makes
        model.set_logger(configure(str(out / "logs" / f"session-{earlier}"),
                                   ["csv", "tensorboard"]))
        steps_from = model.num_timesteps

        validation = make_vec_env(policy, config.envs)  # the environment's own reward
        val_norm = VecNormalize(validation.venv, training=False, norm_reward=False,
                                norm_obs_keys=normalized_keys(validation.venv, policy.obs))
        validation.venv = val_norm

        def sync() -> None:
            val_norm.obs_rms = copy.deepcopy(model.get_vec_normalize_env().obs_rms)

        progress = callbacks.Progress(config.steps, progress_bar)
        best = _Best(out / "best", policy, command)

        def on_scores(step: int, scores: dict[str, float]) -> None:
            progress.show({"val success": scores["success_rate"],
                           "collisions": scores["collision_rate"]})
            best.offer(model, step, scores)

        validate = callbacks.Validation(
            validation, range(VALIDATION_SEED, VALIDATION_SEED + config.eval_seeds),
            config.eval_every, sync, on_scores)
        stages = callbacks.StageCallback(curriculum, stage) if curriculum else None

        # what checkpoints name, besides the step count: DAgger's round and labels
        # (`_imitate` keeps them), the step the value warm-up ends at (0: not started),
        # the curriculum's stage
        resume_at = {key: resumed.get(key, 0) for key in ("imitation_round", "labels",
                                                          "critic_until")
                     } if config.teacher else {}

        def state() -> dict[str, Any]:
            # a checkpoint written as a stage is passed resumes at the next one
            return resume_at | ({"stage": stages.stage + stages.ready} if stages else {})

        checkpoint = callbacks.Checkpoint(checkpoints, config.checkpoint_every, state)
        imitation_s = _imitate(config, model, venv, envs, checkpoints, validate, checkpoint,
                               folder, resume_at) if config.teacher else 0.0
        # the RL phase's own time: validations and checkpoints of the rounds are not in it
        rl_from, rl_other_s = model.num_timesteps, validate.seconds + checkpoint.seconds
        learn_s, stats = 0.0, callbacks.EpisodeStats()
        if config.value_warmup and not resume_at["critic_until"]:
            resume_at["critic_until"] = model.num_timesteps + config.value_warmup
        if config.teacher and model.num_timesteps < resume_at["critic_until"]:
            from lgmd_sim.training.dagger import critic_only

            learn_start = time.perf_counter()
            # the update counter tells the warm-up's updates apart in the logs
            steps, updates = [model.num_timesteps], [model._n_updates]
            with critic_only(model.policy):
                model.learn(total_timesteps=resume_at["critic_until"] - model.num_timesteps,
                            reset_num_timesteps=False,
                            callback=[progress, stats, validate, checkpoint])
            learn_s += time.perf_counter() - learn_start
            folder.session["value_warmup"] = {"steps": [*steps, model.num_timesteps],
                                              "n_updates": [*updates, model._n_updates]}
        while True:
            learn_start, stage_from = time.perf_counter(), model.num_timesteps
            model.learn(total_timesteps=config.steps - model.num_timesteps,
                        reset_num_timesteps=False,
                        callback=[progress, stats, validate, *([stages] if stages else []),
                                  checkpoint])
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
            envs.close()
            envs = make_vec_env(policy, config.envs, config.overrides(stages.stage))
            venv = normalized(envs.venv, policy.obs, policy.algo, kwargs, like=venv)
            seeds = folder.session["env_seeds"]
            venv.seed(seeds[0] + seeds[1])
            folder.session["env_seeds"] = [seeds[0], seeds[1] + config.envs]
            folder.note()  # the stage passed, on record before the next starts
            model.set_env(venv)  # its next learn() resets the new environments
    finally:
        envs.close()
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
    policies.save(out, model, policy, policies.Normalizer.of(venv),
                  steps=model.num_timesteps, command=command,
                  validation=best.last, version=__version__)
    curve.learning_curve(out, f"{out.name}: {trained(config.as_json())}")
    folder.finish()
    write_text_atomic(out / "summary.md", summary_markdown(out))
    files = ["policy.npz", "policy.json", "best/", "learning_curve.png", "summary.md",
             "run.json", "logs/", "checkpoints/"]
    return RunResult(out, validation_rows(out), files)


def _imitate(config: TrainConfig, model: Any, venv: Any, envs: Any, checkpoints: Path,
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
