"""The error contract of the ``bkabem`` command line, shared by every subcommand module.

- **Bad input** (an argument, a case key, an unreadable input or an unwritable output): one line on stderr,
  ``bkabem <command>: error: <argument or key>: <reason>``, exit code 2 (:data:`EXIT_BAD_INPUT`).
- **A failure that is not the input's fault** (a bug): one line naming the exception and the hint to re-run
  with ``--debug``, exit code 1 (:data:`EXIT_FAILURE`); ``--debug`` shows the traceback instead.
- **SIGINT / SIGTERM**: ``bkabem <command>: interrupted``, exit code 130 / 143; the command's ``finally`` blocks
  run (files closed, partial outputs removed). The SIGTERM handler is installed before ``rclpy.init``, which
  keeps it as the handler it chains to, so a long preparation (the 4-DOF integration) stops on SIGTERM too.

Subcommand modules register themselves with ``add_parser(sub)`` and only parse and call: they raise
:class:`UsageError` (or a library's input error, see :data:`INPUT_ERRORS`) and never write errors or exit
themselves. :func:`run_command` applies the contract; ``bkabem_ros.cli.main`` is the ``bkabem`` entry point.
This module imports nothing heavy (no numpy, no rclpy): ``bkabem excitation`` must not pay for ROS.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import traceback

EXIT_BAD_INPUT = 2
EXIT_FAILURE = 1
EXIT_SIGINT = 128 + signal.SIGINT
EXIT_SIGTERM = 128 + signal.SIGTERM

#: Library exceptions that mean "bad input" (``module``, ``class``): matched by name when the module has been
#: imported, so that this module does not import them (or numpy) itself.
INPUT_ERRORS = (("bkabem_core.model.case", "CaseError"), ("bkabem_core.synth.synthesizer", "SynthError"),
("bkabem_ros.recording.mcap_io", "RecorderError"),
                ("bkabem_ros.recording.mcap_check", "DamagedRecording"), ("bkabem_ros.ros_env", "SecurityUnavailable"),
                ("bkabem_ros.ros_env", "RosArgumentsError"), ("bkabem_ros.ros_env", "DiscoverySettingError"))

DEBUG_HELP = "on an unexpected error show the traceback (default: one line)"


class UsageError(Exception):
    """Bad command-line input; the message names the argument (or case key) and the reason."""


class Interrupted(KeyboardInterrupt):
    """SIGTERM, raised like SIGINT's KeyboardInterrupt so that every ``except KeyboardInterrupt`` stop path
    (echo, speed, record, node spin) also handles a polite kill."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class Parser(argparse.ArgumentParser):
    """argparse with the project's error contract: one line on stderr, exit code 2."""

    def error(self, message):  # noqa: D401 - argparse API
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        sys.exit(EXIT_BAD_INPUT)


def add_debug(p: argparse.ArgumentParser, default=argparse.SUPPRESS) -> None:
    """``--debug`` on the main parser (default False) and on each subparser (SUPPRESS: does not overwrite)."""
    p.add_argument("--debug", action="store_true", default=default, help=DEBUG_HELP)


# --------------------------------------------------------------------------- argument types
def finite_float(name: str, minimum: float | None = None, strict: bool = False, maximum: float | None = None):
    """argparse type: a finite float, optionally ``>= minimum`` (``> minimum`` when ``strict``) and
    ``<= maximum``; the message names the argument."""

    def conv(text: str) -> float:
        try:
            if "_" in text:                 # float("1_0") is 10: a typo must not become another number
                raise ValueError(text)
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number (got {text!r})") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{name} must be finite (got {text!r})")
        if minimum is not None and (v <= minimum if strict else v < minimum):
            op = ">" if strict else ">="
            raise argparse.ArgumentTypeError(f"{name} must be {op} {minimum:g} (got {text!r})")
        if maximum is not None and v > maximum:
            raise argparse.ArgumentTypeError(f"{name} must be <= {maximum:g} (got {text!r})")
        return v

    return conv


def pos_int(name: str, minimum: int = 1, maximum: int | None = None):
    """argparse type: an integer ``>= minimum`` (and ``<= maximum``); the message names the argument."""

    def conv(text: str) -> int:
        try:
            if "_" in text:                 # int("1_0") is 10
                raise ValueError(text)
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be an integer (got {text!r})") from None
        if v < minimum:
            raise argparse.ArgumentTypeError(f"{name} must be >= {minimum} (got {v})")
        if maximum is not None and v > maximum:
            raise argparse.ArgumentTypeError(f"{name} must be <= {maximum} (got {v})")
        return v

    return conv


class OutputPath(str):
    """A path given to an output option; remembers the option so that a later write error names it."""

    argument: str = ""


def output_path(name: str, suffixes: tuple[str, ...] = (), make_parents: bool = False):
    """argparse type for a file the command will write: the suffix (when ``suffixes``), an existing writable
    folder and not a folder itself are checked before any work is done (:func:`check_output`). When the command
    fails, a file it created there is removed again (no half-written output that looks like a result)."""

    def conv(text: str) -> OutputPath:
        check_output(name, text, suffixes, make_parents)
        p = OutputPath(text)
        p.argument = name
        return p

    return conv


def check_output(name: str, path, suffixes: tuple[str, ...] = (), make_parents: bool = False) -> None:
    """Raise :class:`argparse.ArgumentTypeError` when ``path`` cannot be a new output file: wrong suffix, a folder,
    a missing folder (created when ``make_parents``), a folder this process cannot create files in (tried: root
    ignores permission bits, a read-only mount or /sys does not)."""
    text = str(path)
    if not text:
        raise argparse.ArgumentTypeError(f"{name}: empty path")
    if suffixes and not text.lower().endswith(tuple(s.lower() for s in suffixes)):
        raise argparse.ArgumentTypeError(f"{name} must end in {' or '.join(suffixes)} (got {text!r})")
    if os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"{name}: {text} is a directory")
    parent = os.path.dirname(os.path.abspath(text))
    if not os.path.isdir(parent):
        if not make_parents:
            raise argparse.ArgumentTypeError(f"{name}: directory {os.path.dirname(text) or '.'} does not exist")
        try:
            os.makedirs(parent, exist_ok=True)
        except OSError as exc:
            raise argparse.ArgumentTypeError(f"{name}: cannot create directory {parent}: {exc.strerror}") from None
    if os.path.exists(text):
        if not os.access(text, os.W_OK):
            raise argparse.ArgumentTypeError(f"{name}: {text} is not writable")
    else:
        why = _cannot_create_in(parent)
        if why:
            raise argparse.ArgumentTypeError(f"{name}: cannot create files in {parent}: {why}")


def _cannot_create_in(folder: str) -> str | None:
    """Why no file can be created in ``folder`` (by trying), or None."""
    import tempfile

    try:
        fd, probe = tempfile.mkstemp(prefix=".bkabem-probe-", dir=folder)
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(fd)
    try:
        os.unlink(probe)
    except OSError:
        pass
    return None


def check_output_dir(name: str, path) -> None:
    """Raise :class:`UsageError` when ``path`` is not a folder this process can create files in (created when
    missing, like ``mkdir -p``)."""
    text = str(path)
    if os.path.exists(text) and not os.path.isdir(text):
        raise UsageError(f"{name}: {text} is not a directory")
    try:
        os.makedirs(text, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{name}: {text}: {exc.strerror}") from None
    why = _cannot_create_in(text)
    if why:
        raise UsageError(f"{name}: cannot create files in {text}: {why}")


class writing:
    """``with writing("--png", path): plot(...)``: an OSError while writing (a full disk: the writer's file object
    has no name in the error) becomes one line naming the option and the path."""

    def __init__(self, option: str, path):
        self.option, self.path = option, path

    def __enter__(self):
        return self

    def __exit__(self, et, exc, tb):
        if isinstance(exc, OSError) and not isinstance(exc, BrokenPipeError):
            raise UsageError(f"{self.option}: {self.path}: {exc.strerror or exc}") from None
        return False


def times_real_time(factor: float) -> str:
    """``"0.31x"``, ``"12x"``, ``"2400x"``: a speed relative to real time, with its digits (never ``"0x"``)."""
    return f"{factor:.0f}x" if factor >= 10 else f"{factor:.2g}x"


# --------------------------------------------------------------------------- the contract
def _input_error_types() -> tuple[type, ...]:
    out = [UsageError, argparse.ArgumentTypeError]
    for mod, cls in INPUT_ERRORS:
        m = sys.modules.get(mod)
        t = getattr(m, cls, None) if m is not None else None
        if isinstance(t, type):
            out.append(t)
    return tuple(out)


def _argument_of(args, filename) -> str | None:
    """The option whose value is ``filename`` (an OSError's file), or None."""
    if not filename:
        return None
    try:
        target = os.path.abspath(os.fsdecode(filename))
    except (TypeError, ValueError):
        return None
    for key, value in vars(args).items():
        values = value if isinstance(value, (list, tuple)) else [value]
        for v in values:
            if isinstance(v, (str, os.PathLike)) and v and os.path.abspath(os.fspath(v)) == target:
                if isinstance(v, OutputPath) and v.argument:
                    return v.argument
                return key if key == "file" else "--" + key.replace("_", "-")
    return None


def _os_error_line(args, exc: OSError) -> str:
    name = exc.filename or ""
    arg = _argument_of(args, name)
    what = exc.strerror or str(exc)
    if name:
        return f"{arg}: {name}: {what}" if arg else f"{name}: {what}"
    return what


def _on_sigterm(signum, _frame):
    signal.signal(signal.SIGTERM, signal.SIG_IGN)      # a second one while the first is handled: no traceback
    raise Interrupted(signum)


def run_command(args, command: str | None = None) -> int:
    """Run ``args.func(args)`` under the error contract and return the exit code (see the module docstring)."""
    command = command or getattr(args, "command", "") or ""
    prog = f"bkabem {command}".strip()
    try:
        old_term = signal.signal(signal.SIGTERM, _on_sigterm)
        old_int = signal.getsignal(signal.SIGINT)
    except ValueError:          # not the main thread (a test calling main() from a thread): leave it
        old_term = old_int = None
    new_outputs = [p for p in _output_paths(args) if not os.path.lexists(p)]
    rc = EXIT_FAILURE
    try:
        rc = _run(args, prog)
        return rc
    finally:
        if old_term is not None:
            signal.signal(signal.SIGTERM, old_term)
            if old_int is not None:                 # None: a handler installed outside Python
                signal.signal(signal.SIGINT, old_int)
        if rc not in (0, None):
            _remove_partial(new_outputs)


def _run(args, prog: str) -> int:
    debug = bool(getattr(args, "debug", False)) or os.environ.get("BKABEM_DEBUG", "") not in ("", "0")
    if sys.stdout is None:                  # started with stdout closed (`>&-`): results would be lost
        sys.stderr.write(f"{prog}: error: stdout: closed (the command writes its results and progress there; "
                         f"redirect it to a file or /dev/null)\n")
        return EXIT_BAD_INPUT
    try:
        _ros_environment(args, prog)
        rc = int(args.func(args) or 0)
        sys.stdout.flush()        # a full or closed stdout is an error of this command, not of the interpreter
        return rc
    except KeyboardInterrupt as exc:
        _ignore_further_interrupts()
        sys.stderr.write(f"{prog}: interrupted\n")
        return EXIT_SIGTERM if isinstance(exc, Interrupted) else EXIT_SIGINT
    except BrokenPipeError:
        _silence_stdout()
        return 0                  # `bkabem sweep --csv | head`: the reader has what it wanted
    except SystemExit:
        raise
    except MemoryError:
        sys.stderr.write(f"{prog}: error: out of memory: the input asks for more than this machine has (a case "
                         f"whose [plausibility] table widens a computing limit?)\n")
        return EXIT_BAD_INPUT
    except Exception as exc:  # noqa: BLE001 - the contract: one line, never a traceback unless asked
        if isinstance(exc, _input_error_types()):
            sys.stderr.write(f"{prog}: error: {_one_line(str(exc))}\n")
            return EXIT_BAD_INPUT
        if isinstance(exc, OSError):
            if exc.filename is None and _is_stdout_error(exc):
                _silence_stdout()
                sys.stderr.write(f"{prog}: error: stdout: {exc.strerror or exc}\n")
                return EXIT_BAD_INPUT
            sys.stderr.write(f"{prog}: error: {_one_line(_os_error_line(args, exc))}\n")
            return EXIT_BAD_INPUT
        if debug:
            traceback.print_exc()
        else:
            sys.stderr.write(f"{prog}: error: unexpected {type(exc).__name__}: {_one_line(str(exc))} "
                             f"(a bug: re-run with --debug for the traceback)\n")
        return EXIT_FAILURE


def _ignore_further_interrupts() -> None:
    """While an interrupt is handled (files closed, partial outputs removed), a second SIGINT / SIGTERM must not
    end the process with a traceback from inside the handler; the handlers are restored by :func:`run_command`."""
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
    except ValueError:            # not the main thread
        pass


def _ros_environment(args, prog: str) -> None:
    """For a command that joins the ROS graph (``set_defaults(ros_network=True)`` or a predicate of the args):
    loopback discovery unless the user chose, no DDS security (:func:`bkabem_ros.ros_env.apply_defaults`); the
    command announces the range right before ``rclpy.init``."""
    net = getattr(args, "ros_network", False)
    if callable(net):
        net = net(args)
    if not net:
        return
    from bkabem_ros.ros_env import apply_defaults, apply_discovery_options

    apply_discovery_options(args)       # --discovery-* options -> the standard variables (checked)
    quiet = bool(getattr(args, "quiet", False))
    apply_defaults(say=None if quiet else (lambda line: sys.stderr.write(f"{prog}: {line}\n")))


def _output_paths(args) -> list[str]:
    out = []
    for value in vars(args).values():
        for v in (value if isinstance(value, (list, tuple)) else [value]):
            if isinstance(v, OutputPath):
                out.append(str(v))
    return out


def _remove_partial(paths: list[str]) -> None:
    """Remove regular files a failed command created at its output paths (never links, devices or folders)."""
    import stat

    for p in paths:
        try:
            if stat.S_ISREG(os.lstat(p).st_mode):
                os.unlink(p)
        except OSError:
            pass


def _one_line(text: str, limit: int = 600) -> str:
    s = " ".join(str(text).split())
    return s if len(s) <= limit else s[:limit - 3] + "..."


def _is_stdout_error(exc: OSError) -> bool:
    try:
        sys.stdout.flush()
    except OSError:
        return True
    return False


def _silence_stdout() -> None:
    """After a failed write to stdout: point it at /dev/null so the interpreter's exit flush stays quiet."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


def add_ros_options(sp) -> None:
    """The discovery options (:func:`bkabem_ros.ros_env.add_discovery_options`) on a subcommand that joins the
    ROS graph (``ros_network`` default set, a value or a predicate of the args)."""
    if sp.get_default("ros_network") and not any(a.dest == "discovery_range" for a in sp._actions):
        from bkabem_ros.ros_env import add_discovery_options

        add_discovery_options(sp)


def subcommand_main(name: str, add_parser, argv=None) -> int:
    """``python -m <module> ARGS`` = ``bkabem <name> ARGS`` for a module that registers one subcommand."""
    parser = Parser(prog="bkabem")
    add_debug(parser, default=False)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    sp = add_parser(sub)
    if sp is not None and not any(a.dest == "debug" for a in sp._actions):
        add_debug(sp)
    if sp is not None:
        add_ros_options(sp)
    return run_command(parser.parse_args([name, *(sys.argv[1:] if argv is None else argv)]))


def fail(command: str, message: str):
    """Bad input of ``command``: raise :class:`UsageError` (the command line writes the one line, exit code 2)."""
    raise UsageError(message)


def check_parameter_ranges(overrides: dict, option_of=lambda name: "--" + name.replace("_", "-")) -> None:
    """The node's parameter ranges (node_params.PARAMETERS) for the shorthand options, before rclpy starts: bad input is
    one line, not a log of the node's start-up followed by rclpy's refusal."""
    from bkabem_ros.node.params import PARAMETER_SPECS

    for name, value in overrides.items():
        spec = PARAMETER_SPECS.get(name)
        if spec is None or spec.range is None or isinstance(value, (bool, str)):
            continue
        lo, hi = spec.range
        if not lo <= value <= hi:
            unit = f" {spec.unit}" if spec.unit else ""
            raise UsageError(f"{option_of(name)}: {value:g}{unit} is outside the parameter's range "
                             f"{lo:g} .. {hi:g}{unit}")
