"""The `video` presets' section of docs/experiments/models-log.md, and the README's
detection figure, from a video calibration run (`lgmd-sim calibrate --task video`). Every
table and figure comes from the run's files or from the shipped presets; the section
replaces the one between the markers (or is appended), the rest of the page stays.

    .venv/bin/python docs/experiments/tools/video_page.py runs/calibration-video runs/footage-check

or, for docs/video/detect.png alone (it needs no run: a clip of its own):

    .venv/bin/python docs/experiments/tools/video_page.py --detect-figure-only

Writes, besides the section: docs/video/calibration.png (the run's; drawn again, without
the run, from what docs/results/calibration-video keeps of it by
docs/experiments/tools/calibration_figure.py), potentials.png (a
shaken synthetic approach in a look the calibration never saw, each video preset with and
without each part of its front end) and detect.png (the README's: `lgmd-sim detect
--preset video` against the published defaults on a clip recorded with a real camera's
noise).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from lgmd_sim import models
from lgmd_sim.calibration import clips as clip_mod
from lgmd_sim.calibration.objective import THRESHOLDS, VIDEO, unpack_hits
from lgmd_sim.calibration.report import summary_markdown
from lgmd_sim.calibration.run import choose
from lgmd_sim.calibration.search import CONTROLS, Candidate, evaluate, space
from lgmd_sim.calibration.tasks import TASKS, preset_name
from lgmd_sim.core.fileio import write_files
from lgmd_sim.core.plots import model_style
from lgmd_sim.signals import noise, stimuli

ROOT = Path(__file__).resolve().parents[3]
PAGE = ROOT / "docs" / "experiments" / "models-log.md"
FIGURES = ROOT / "docs" / "video"
#: The figures' folder as the page links it (relative to the page).
FIGURES_LINK = Path(os.path.relpath(FIGURES, PAGE.parent)).as_posix()
BEGIN = "<!-- video: made by docs/experiments/tools/video_page.py from the run named below -->"
END = "<!-- video: end -->"
#: The README's clip: a seed outside the run's sets, in the transfer looks (a worse
#: camera than the calibration's own, a scene lit as none of its clips were).
CLIP = ("HandheldApproach", 1.0, 4242)
LOOKS = clip_mod.VIDEO_LOOKS["transfer"]
#: The front ends' figure's stimulus: in the calibration's own looks (a textured ground
#: for the rotation fit to track), a seed outside the run's sets.
STIMULUS_LOOKS = clip_mod.VIDEO_LOOKS[""]
#: The front ends compared: what a video preset has, and each part of it taken away; the
#: line of each in the model's colour.
FRONTS = {"none": {"stabilize": "none", "gain": False},
          "image": {"stabilize": "image", "gain": False},
          "image+gain": {}}
DASHES = {"none": "-", "image": (0, (5, 2)), "image+gain": (0, (1, 1.2))}
#: The option that draws the README's figure (docs/video/detect.png) alone, from no run.
DETECT_ONLY = "--detect-figure-only"
#: Where the footage targets (`footage_check.TARGETS`) come from.
TARGETS_SOURCE = "issue 18's (detection that transfers to real footage)"


def _front_style(name: str) -> dict:
    """A line of the front ends' figure ("model/video, front end F"): the model's colour,
    the front end's dashes."""
    model, _, front = name.partition(", front end ")
    return {**model_style(model.partition("/")[0]), "ls": DASHES[front], "lw": 1.6}


def _chosen(run: Path) -> tuple[list[dict], dict[str, list[dict]], dict]:
    """Each detector's chosen candidate (as the calibration chose it), the clip sets and
    the run record."""
    record = json.loads((run / "run.json").read_text())
    config = record["config"]
    task = TASKS["video"]
    first, n = config["heldout_seeds"]
    seeds = list(range(first, first + n))
    names = {"heldout": clip_mod.specs(task.groups, seeds),
             **{look: clip_mod.specs(task.groups, seeds, look) for look in task.looks if look}}
    first, n = config["search_seeds"]
    names = {"search": clip_mod.specs(task.groups, list(range(first, first + n))), **names}
    # in the order the run scored them: its records' (lgmd_sim.core.runs.RunFolder.records)
    clip_sets = {s: [{**json.loads((run / "records" / f"clip-{c.key}.json").read_text()),
                      "scenario": c.scenario} for c in sorted(specs, key=lambda c: c.key)]
                 for s, specs in names.items()}
    chosen = []
    for detector in config["detectors"]:
        recs = [json.loads(p.read_text())
                for p in sorted((run / "records").glob(f"{detector}-*.json"))]
        best = choose(recs, clip_sets, VIDEO)
        best["hits"] = {s: unpack_hits(recs[best["candidate"]]["sets"][s], len(clip_sets[s]))
                        for s in clip_sets}
        chosen.append(best)
    return chosen, clip_sets, record


def silence_table(chosen: Sequence[dict], clip_sets: dict[str, list[dict]]) -> list[str]:
    """Per detector and stimulus that does not loom (and the near misses): the clips it
    fired on, held-out and transfer."""
    kinds = [name for name, _ in clip_mod.VIDEO_GROUPS["non_looming"]]
    kinds += [name for name, _ in clip_mod.VIDEO_GROUPS["near_miss"]]
    sets = [s for s in clip_sets if s != "search"]
    lines = ["| detector | " + " | ".join(kinds) + " |", "|---|" + "---:|" * len(kinds)]
    for c in chosen:
        at = int(np.flatnonzero(np.isclose(THRESHOLDS, c["threshold"]))[0])
        cells = []
        for kind in kinds:
            parts = []
            for s in sets:
                rows = [i for i, clip in enumerate(clip_sets[s]) if clip["scenario"] == kind]
                fired = int((~c["hits"][s][rows, at]).sum())  # a hit here is silence
                parts.append(f"{fired}/{len(rows)}")
            cells.append(" / ".join(parts))
        lines.append(f"| {c['detector']} | " + " | ".join(cells) + " |")
    return lines


def front_table(run: Path, chosen: Sequence[dict], clip_sets: dict[str, list[dict]]
                ) -> list[str]:
    """Per model, the objective (held-out / transfer) of its published defaults, of its
    video preset's parameters and threshold without the front end, and of the video
    preset: what the calibration and the front end each bring. Evaluated here on the run's
    clips, as the calibration evaluates a candidate."""
    sets = {s: recs for s, recs in clip_sets.items() if s != "search"}
    kinds = {s: np.array([r["kind"] for r in recs]) for s, recs in sets.items()}
    lines = ["| model | published defaults, no front end | video parameters, no front end "
             "| video preset |", "|---|---:|---:|---:|"]
    for c in chosen:
        if c["detector"].partition("+")[0] in CONTROLS:
            continue  # the feedback LGMD's control: a detector, not a model's preset
        model = space(c["detector"]).model
        published = models.make(model).params.threshold
        cells = []
        for candidate, threshold in ((Candidate(model, 0, {}), published),
                                     (Candidate(model, c["candidate"], c["params"]),
                                      c["threshold"])):
            scores = evaluate(candidate, str(run / "clips"), sets, VIDEO)["sets"]
            at = int(np.flatnonzero(np.isclose(THRESHOLDS, threshold))[0])
            cells.append(" / ".join(
                f"{VIDEO.value(kinds[s], scores[s], slice(at, at + 1))[0][0]:.3f}"
                for s in sets))
        cells.append(" / ".join(f"{c[s]['objective']:.3f}" for s in sets))
        lines.append(f"| {model} | " + " | ".join(cells) + " |")
    return lines


def _shaken_approach(shape: tuple[int, int]) -> stimuli.Stimulus:
    look = stimuli.Look(polarity="dark", contrast=0.5, background=STIMULUS_LOOKS.background,
                        seed=7)
    return stimuli.jittered(stimuli.approaching(shape, look=look), 1.0, 7)


def potentials_figure(out: Path, names: Sequence[str]) -> None:
    """Each video preset on a shaken synthetic approach with a real camera's noise, with
    its whole front end, with the rotation alone and with none."""
    from lgmd_sim.core.plots import figure
    from lgmd_sim.detect import detect
    from lgmd_sim.detect.figure import draw_potentials

    clip = _shaken_approach((120, 160))
    parsed = noise.parse(STIMULUS_LOOKS.noise)
    frames = [noise.apply(f, parsed, 7, t) for t, f in enumerate(clip.frames)]
    fig = figure(figsize=(6.0 * len(names), 5.8))
    axes = np.atleast_1d(fig.subplots(1, len(names), sharey=True))
    for ax, name in zip(axes, names, strict=True):
        built = {f"{name}/video, front end {front}": models.make(name, preset="video", **p)
                 for front, p in FRONTS.items()}
        d = detect(frames, clip.fps, built, clip.collision_frame, name=name)
        draw_potentials(ax, d, legend=False, style_of=_front_style)
        # below the axes: the first alarms come late, near the top of the panel
        ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(0.0, -0.14))
        ax.set_title(name, fontsize="medium")
    fig.suptitle(f"a dark square looming at a camera shaking at jitter 1, with the noise "
                 f"{STIMULUS_LOOKS.noise}", fontsize="medium")
    write_files({out: lambda tmp: fig.savefig(tmp, format="png", dpi=100)})


def detect_figure(out: Path) -> tuple[str, int]:
    """The README's figure: one panel per model, each at its defaults and at ``--preset
    video`` on one clip with a real camera's noise (`lgmd_sim.detect.figure.draw_by_model`);
    returns the clip's description and collision frame."""
    import dataclasses

    import gymnasium as gym

    from lgmd_sim.controllers import Straight, rollout
    from lgmd_sim.core.pngtext import png_text
    from lgmd_sim.detect import detect
    from lgmd_sim.detect.figure import detection_figure
    from lgmd_sim.detect.specs import with_preset
    from lgmd_sim.envs.catalogue import scenario

    name, jitter, seed = CLIP
    fovy = float(np.random.default_rng(seed).uniform(*clip_mod.VIDEO_FOVY_RANGE))
    env = gym.make(scenario(name).env_id, jitter=jitter, resolution=(270, 480), fovy=fovy,
                   **LOOKS.scene)
    steps = list(rollout(env, Straight(), seed=seed))
    env.close()
    frames = [s.obs["frame"] for s in steps]
    hit, fps = int(steps[-1].info["first_collision_frame"]), env.unwrapped.params.fps
    parsed = noise.parse(LOOKS.noise)
    frames = [noise.apply(f, parsed, seed, t) for t, f in enumerate(frames)]
    names = models.available()
    # `lgmd-sim detect CLIP` and `lgmd-sim detect CLIP --preset video`, as one detection:
    # each model's panel holds both
    runs = [detect(frames, fps, with_preset(names, preset), hit, name=name)
            for preset in (None, "video")]
    both = dataclasses.replace(runs[0], models={k: v for d in runs for k, v in d.models.items()})
    described = (f"{name}, jitter {jitter:g}, seed {seed}, 270 x 480, a camera of {fovy:.0f} "
                 f"degrees (vertical), low sun, shade and flicker, with the noise "
                 f"{LOOKS.noise}")
    title = (f"{described}:\neach model at its published defaults (lgmd-sim detect CLIP) and "
             "at --preset video (MODEL/video, the darker line)")
    fig = detection_figure(both, title=title, ssim=False, width=13.0)
    fig.suptitle(title, fontsize="medium")
    text = png_text(f".venv/bin/python docs/experiments/tools/video_page.py {DETECT_ONLY}",
                    {"clip": list(CLIP), "noise": LOOKS.noise, "models": list(both.models)})
    write_files({out: lambda tmp: fig.savefig(tmp, format="png", dpi=90, metadata=text)})
    return described, hit


def footage_lines(folder: Path) -> list[str]:
    """The outside check's protocol on clips of our own (the run of
    docs/experiments/tools/footage_check.py in `folder`): its command, what the clips are, the
    table with the targets missed."""
    from footage_check import FIRST_SEED, HELDOUT_SEED, KINDS, LOOKS, SHAKE, TARGETS, table

    record = json.loads((folder / "footage_check.json").read_text())
    if record["seeds"][0] != HELDOUT_SEED:
        sys.exit(f"video_page.py: {folder} holds the footage check of seeds "
                 f"{record['seeds'][0]} and up; the page shows the held-out ones "
                 f"(docs/experiments/tools/footage_check.py DIR --first-seed {HELDOUT_SEED})")
    h, w = record["resolution"]
    seeds = record["seeds"]
    kinds = {k: ", ".join(sorted({s for s, _ in v})) for k, v in KINDS.items()}
    return [
        "### The outside check's protocol, on clips of our own", "",
        "The project's targets for footage are judged on clips held outside the "
        "repository, so that no preset is tuned to them: stimuli that loom and that do "
        "not, real crash videos, and the same crashes with a per-frame shake and flicker, "
        "each through `lgmd-sim detect --preset video` with no other option. The same "
        "protocol on clips of our own, from seeds no calibration used "
        f"({seeds[0]} to {seeds[-1]}) at {h} x {w}: approaching ({kinds['approaching']}), "
        f"non-approach ({kinds['non_approach']}), crashes ({kinds['crash']}, cameras of "
        f"{clip_mod.VIDEO_FOVY_RANGE[0]:g} to {clip_mod.VIDEO_FOVY_RANGE[1]:g} degrees, "
        f"noise {LOOKS.noise}, a sun at {LOOKS.scene['sun_elevation']:g} degrees and "
        f"shade {LOOKS.scene['shade']:g}: a light no calibration clip had), and the crashes "
        f"again with {SHAKE} on top (per frame: a shift of sd 2 px, a roll of sd 1 degree, "
        "a gain of sd 5%):", "",
        "```bash", f".venv/bin/python {record['command']}", "```", "",
        f"The targets, {TARGETS_SOURCE}, for the best model: approaching clips fired on "
        f"{100 * TARGETS['approaching']:g}%, non-approach clips fired on "
        f"{100 * TARGETS['non_approach']:g}% or fewer, crashes fired on "
        f"{100 * TARGETS['crash']:g}% or more, the shaken crashes' mean SI "
        f"{TARGETS['si']:g} or more; `targets missed` names those a detector misses:", "",
        table(record["rows"]), "",
        f"The video presets' alarm rule ({VIDEO.alarm.frames} frames running and rising, "
        f"against {VIDEO.alarm.frames} frames alone) was chosen on the check's clips of "
        f"seeds {FIRST_SEED} and up; the table is of seeds {HELDOUT_SEED} and up, looked "
        "at after that choice.", "",
    ]


def _shown(run: Path) -> str:
    return str(run.relative_to(ROOT)) if run.is_relative_to(ROOT) else str(run)


def _wall(record: dict) -> str:
    return f"{record['wall_time_s'] / 60:.0f} min"


def section(run: Path, footage: Path) -> str:
    chosen, clip_sets, record = _chosen(run)
    write_files({FIGURES / "calibration.png":
                 lambda tmp: tmp.write_bytes((run / "calibration.png").read_bytes())})
    potentials_figure(FIGURES / "potentials.png", ["feedback", "lgmd1"])
    described, _ = detect_figure(FIGURES / "detect.png")
    presets = ", ".join(f"`{'/'.join(preset_name(c['detector'], 'video'))}`" for c in chosen)
    config = record["config"]
    lines = [
        BEGIN, "", "## Footage from any camera: the `video` presets", "",
        "For a video from a camera nobody calibrated, `lgmd-sim detect VIDEO --preset "
        "video` runs every model with the front end such footage needs (the camera's "
        "rotation between frames fitted from the frames, assuming a vertical field of "
        f"view of {clip_mod.VIDEO_FOVY:g} degrees, and the brightness gain between "
        f"frames), each frame shrunk to the height of the calibration's clips "
        f"({models.make('feedback', preset='video').params.working_height} rows: a "
        "model's kernels are in pixels), and the parameters and threshold of a calibration "
        f"made for it, an alarm needing {VIDEO.alarm.frames} frames running above the "
        f"threshold{', never falling' if VIDEO.alarm.rising else ''}: {presets}. The "
        "published defaults (`lgmd-sim detect VIDEO`) are the models as their papers "
        "give them, for fidelity: use them to reproduce a paper, the video presets to "
        "detect collisions in footage of your own.", "",
        "The calibration, with its own seeds and the same budget for every model:", "",
        "```bash", record["command"], "```", "",
        f"Wall time {_wall(record)}. Search seeds {config['search_seeds'][0]} and up, "
        f"held-out {config['heldout_seeds'][0]} and up, {config['search_seeds'][1]} per "
        "clip group; the shipped `video` presets are this run's "
        f"(`docs/experiments/tools/ship_presets.py {_shown(run)}`).", "",
        "```text", VIDEO.text, "```", "",
        "### Transfer", "",
        "Search, held-out, and transfer: the held-out seeds in looks the search never saw "
        f"({LOOKS.noise}; the scene with low sun, passing shade and flicker; the stimuli on "
        "plain grounds). Each part is a kind's hit rate in the same order:", "",
        *summary_markdown(chosen, VIDEO).splitlines(), "",
        f"![docs/video/calibration.png]({FIGURES_LINK}/calibration.png)", "",
        "What the calibration and the front end each bring: each model's objective "
        "(held-out / transfer) at its published defaults with no front end, with its video "
        "preset's parameters and threshold but no front end, and at its video preset, "
        "every column scored by the objective, its alarm rule included:", "",
        *front_table(run, chosen, clip_sets), "",
        "### What does not loom", "",
        "The clips each video preset fired on (held-out / transfer): stimuli that move "
        "without looming (receding, crossing, turning, a drifting grating, the whole field "
        "dimming and lightening), steady and shaken, and the scenes' near misses:", "",
        *silence_table(chosen, clip_sets), "",
        *footage_lines(footage),
        "### Each part of the front end", "",
        "The feedback LGMD and LGMD1 at their video presets, with the whole front end, "
        "with the rotation alone, and with none, on a synthetic approach shaken at "
        f"jitter 1 on a textured ground, with the calibration's own noise "
        f"({STIMULUS_LOOKS.noise}) and a seed outside its sets:", "",
        f"![docs/video/potentials.png]({FIGURES_LINK}/potentials.png)", "",
        f"The README's figure: {described}.", "",
        f"![docs/video/detect.png]({FIGURES_LINK}/detect.png)", "",
        END,
    ]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, nargs="?", help="the video calibration's run folder")
    ap.add_argument("footage", type=Path, nargs="?",
                    help="docs/experiments/tools/footage_check.py's output folder (its "
                    "footage_check.json)")
    ap.add_argument(DETECT_ONLY, action="store_true",
                    help="draw docs/video/detect.png alone (no run needed), the page as it is")
    args = ap.parse_args(argv)
    if args.detect_figure_only:
        detect_figure(FIGURES / "detect.png")
        print("wrote docs/video/detect.png")
        return
    if args.run is None or args.footage is None:
        ap.error(f"give the run and the footage folders (or {DETECT_ONLY})")
    run = args.run.resolve()
    if json.loads((run / "run.json").read_text()).get("status") != "complete":
        sys.exit(f"video_page.py: {run} is not a complete run")
    text = section(run, args.footage)
    page = PAGE.read_text()
    start, end = page.find(BEGIN), page.find(END)
    page = (page[:start] + text + page[end + len(END) + 1:] if start >= 0 and end > start
            else page.rstrip("\n") + "\n\n" + text)
    write_files({PAGE: lambda tmp: tmp.write_text(page)})
    print(f"wrote {PAGE.relative_to(ROOT)} and docs/video/")


if __name__ == "__main__":
    main()
