"""What the subcommands share: argument types that reject a bad value with the message of
the configuration field's own check; options made from a configuration's fields
(`option`), its --config file (`add_config_file`) and the configuration made of both
(`configured`); the "advanced" group that --help lists after the options a user needs
first; the run-folder, parallel and detector options; the line a user's error prints; and
the printout of a job that keeps a run folder."""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from lgmd_sim.core.params import Check, FieldError, comma_list, count, non_negative, seed

if TYPE_CHECKING:
    from lgmd_sim.core.parallel import RunOptions

#: What an option helper adds its arguments to: a parser, or one of its groups.
Options = argparse._ActionsContainer


def argtype(parse: Callable[[str], Any], check: Check) -> Callable[[str], Any]:
    """An argparse type: the text parsed by `parse` (int, float) and held to `check`, the
    `lgmd_sim.core.params` check a configuration holds the same field to, so that the
    option and the field refuse the same values with the same words."""

    def convert(text: str) -> Any:
        try:
            value = parse(text)
        except ValueError:
            value = text  # not even a number: the check says what it must be
        error = check(value)
        if error:
            raise argparse.ArgumentTypeError(f"{error}, got {text}")
        return value

    return convert


positive_int = argtype(int, count)
non_negative_int = argtype(int, seed)
non_negative_float = argtype(float, non_negative)


def resolution(text: str) -> str | tuple[int, int]:
    """A named frame size (paper, rl, small) or HEIGHTxWIDTH, as the Python API takes it
    (`lgmd_sim.world.params.parse_resolution`)."""
    from lgmd_sim.world.params import parse_resolution

    try:
        return parse_resolution(text)
    except FieldError as exc:
        raise argparse.ArgumentTypeError(exc.problem) from None


def error_line(error: Exception, parser: argparse.ArgumentParser,
               args: argparse.Namespace) -> str:
    """A user's error as the command prints it: a `FieldError` naming the option that set
    its field (the field `first_seed` is ``--first-seed``) where one of the command's options
    sets it, an OSError its file and reason (`lgmd_sim.core.fileio.error_text`)."""
    from lgmd_sim.core.fileio import error_text

    if not isinstance(error, FieldError) or str(error) != f"{error.field} {error.problem}":
        return error_text(error)
    while subs := [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]:
        parser = subs[0].choices[getattr(args, subs[0].dest)]
    flags = [a.option_strings[-1] for a in parser._actions
             if a.dest == error.field and a.option_strings]
    return f"{flags[0]} {error.problem}" if flags else str(error)


def advanced(p: argparse.ArgumentParser, about: str) -> argparse._ArgumentGroup:
    """`p`'s research and tuning options: --help lists them under "advanced", after the
    options a user needs first, with `about` saying what they are for. Where an option is
    listed changes nothing of how it parses."""
    return p.add_argument_group("advanced", about)


def workers(text: str) -> int | str:
    """--workers: a number of local worker processes, or "ray"."""
    if text == "ray":
        return text
    try:
        return positive_int(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1 or ray, got {text}") from None


def add_parallel_options(p: Options, unit: str = "episodes") -> None:
    """--workers and --no-progress: where a command's independent jobs run."""
    p.add_argument("--workers", type=workers, metavar="N|ray", default=None,
                   help=f"local worker processes (default: every core), or ray: the {unit} as "
                   "Ray tasks, on the cluster the RAY_ADDRESS variable names (auto or "
                   "HOST:PORT) or on a Ray started here (needs the ray extra)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def add_run_folder_options(p: Options, default: str) -> None:
    """--out and --resume of a command that keeps its results in a run folder."""
    p.add_argument("--out", default=default, metavar="DIR",
                   help=f"output folder (default ./{default})")
    p.add_argument("--resume", action="store_true",
                   help="complete the run in DIR (same configuration): finished jobs are "
                   "kept")


def run_options(args: argparse.Namespace) -> RunOptions:
    """How a job given the options of `add_parallel_options` (and `add_run_folder_options`,
    where it has them) runs, checked before it starts."""
    from lgmd_sim.core.parallel import RunOptions

    ray = args.workers == "ray"
    return RunOptions(workers=None if ray else args.workers,
                      ray_address=(os.environ.get("RAY_ADDRESS") or "local") if ray else None,
                      progress=False if args.no_progress else None,
                      resume=getattr(args, "resume", False), command=args.command_line)


def print_result(table: str, result: Any) -> int:
    """A job's summary table, then the files it wrote (a `lgmd_sim.core.runs.RunResult`)."""
    print(table, end="")
    print(f"wrote {result.path}/: {', '.join(result.files)}")
    return 0


def add_detector_options(p: Options, default: str | None = "all",
                         means: str = "all, each at its default preset") -> None:
    """--models and --presets: the detectors a benchmark compares (--models `default`,
    which `means` what the help says)."""
    p.add_argument("--models", default=default,
                   help="'all' or a comma-separated list of MODEL or MODEL/PRESET, each "
                   f"optionally with front ends (e.g. lgmd1/calibrated+image); default {means}")
    p.add_argument("--presets", default=None,
                   help="comma-separated presets: each model listed without a preset runs "
                   "each of these it has (its default when it has none of them)")


def names(text: str) -> tuple[str, ...]:
    """A comma-separated list's items (`lgmd_sim.core.params.comma_list`)."""
    return tuple(comma_list(text))


def _spelled(default: Any) -> str:
    """A field's default as an option spells it (a list comma-separated, 1.0 as 1)."""
    if isinstance(default, list):
        return ",".join(map(_spelled, default))
    return f"{default:g}" if isinstance(default, float) else str(default)


def option(p: Options, cls: type, name: str, *, shown: str | None = None,
           beside: tuple[str, type] | None = None, **kwargs: Any) -> None:
    """--NAME (`name`, its ``_`` as ``-``): field `name` of configuration `cls`, whose help
    is the field's meaning and default as `cls` declares them
    (`lgmd_sim.core.configfile.setting`; `shown`: the default as the option spells it, ""
    where the field's text says it; `beside`: (an option, the configuration it makes
    instead), whose default the help gives too). Unset (None) unless given, so that a
    --config file's key, or else the field's default, applies (`configured`)."""
    from lgmd_sim.core.configfile import defaults, doc

    default = defaults(cls)[name]
    listed = isinstance(default, list) or (default is None and kwargs.get("type") is names)
    shown = _spelled(default) if shown is None else shown
    if beside is not None:
        shown += f"; with {beside[0]} {_spelled(defaults(beside[1])[name])}"
    about = [*(["comma-separated"] if listed else []), *([f"default {shown}"] if shown else [])]
    text = f"{doc(cls, name)} ({'; '.join(about)})" if about else doc(cls, name)
    p.add_argument("--" + name.replace("_", "-"), default=None,
                   help=text.replace("%", "%%"), **kwargs)


def add_config_file(p: Options, about: str, *classes: type) -> None:
    """--config FILE.toml: any field of the command's configuration as a KEY = VALUE line
    (`classes`: the configurations it makes, the first unless the help says otherwise),
    `about` saying which fields only a file sets. The option keeps `classes`
    (``config_classes``): the command line's reference lists their keys."""
    made = " or ".join(cls.__name__ for cls in classes)
    action = p.add_argument(
        "--config", metavar="FILE.toml",
        help=f"settings as KEY = VALUE lines of a TOML file, KEY a field of {made}: "
        f"{about} and any other (docs/reference/cli.md lists them); the options given "
        "override the file")
    action.config_classes = classes  # type: ignore[attr-defined]


def configured(cls: type, args: argparse.Namespace, given: dict[str, Any]) -> Any:
    """Configuration `cls` of the options `given` (field -> value, None where not given)
    over the keys of the --config file, over the fields' defaults.

    Raises:
        ValueError: a file that cannot be read, is not TOML or holds another key; a value
            `cls` refuses (one line, naming the file where its key is at fault).
    """
    from lgmd_sim.core.configfile import read_toml

    file = getattr(args, "config", None)  # a command without --config: its options only
    read = read_toml(file, cls) if file else {}
    from_file = {k: v for k, v in read.items() if given.get(k) is None}
    try:
        return cls(**from_file, **{k: v for k, v in given.items() if v is not None})
    except FieldError as exc:
        if exc.field in from_file:
            raise ValueError(f"{file}: {exc}") from None
        raise
