# SPDX-License-Identifier: Apache-2.0
"""The one `main()` life cycle every node shares: arguments, init, build, spin, clean shutdown.

A user mistake (an unreadable `--params-file`, a bad `--ros-args` rule, a bad parameter) ends the process
with exit code 2 and one line on stderr; `--help` prints usage without initialising ROS; one or two
SIGINTs or a SIGTERM end it with exit code 0 and no traceback, whatever callback was running.
"""

from __future__ import annotations

import contextlib
import signal
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import rclpy
import yaml
from rclpy.exceptions import NameValidationException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from swir_tracker_ros.errors import ParameterError

N = TypeVar("N", bound=Node)
ROS_ARGS, END_ROS_ARGS = "--ros-args", "--"
HELP_FLAGS = ("-h", "--help")


def split_arguments(argv: list[str]) -> tuple[list[str], list[str]]:
    """(user arguments, ROS arguments) after the program name: what lies inside `--ros-args ... [--]`
    blocks and what lies outside (never raises, unlike `rclpy.utilities.remove_ros_args` on a malformed
    rule)."""
    user: list[str] = []
    ros: list[str] = []
    in_ros = False
    for arg in argv[1:]:
        if arg == ROS_ARGS:
            in_ros = True
        elif in_ros and arg == END_ROS_ARGS:
            in_ros = False
        else:
            (ros if in_ros else user).append(arg)
    return user, ros


def user_arguments(argv: list[str]) -> list[str]:
    """The arguments after the program name outside `--ros-args ... [--]` blocks."""
    return split_arguments(argv)[0]


def _ros_option(argv: list[str], flags: tuple[str, ...]) -> list[str]:
    """The values of `flags` inside `--ros-args` blocks ('' when a flag ends them)."""
    ros = split_arguments(argv)[1]
    return [ros[i + 1] if i + 1 < len(ros) else "" for i, arg in enumerate(ros) if arg in flags]


def check_ros_args(argv: list[str]) -> None:
    """`ParameterError` naming the rule or file and the problem for a `-p` rule without a value, or a
    `--params-file` that is missing, unreadable or not YAML of the form `<node or /**>:
    {ros__parameters: {...}}` (rcl's own message is several lines with C source locations)."""
    for rule in _ros_option(argv, ("-p", "--param")):
        name, sep, value = rule.partition(":=")
        if not sep or not name:
            raise ParameterError(f"-p {rule}: a parameter rule is name:=value")
        if not value.strip():
            raise ParameterError(f"-p {rule}: the value is missing (an empty string is written "
                                 f"-p '{name}:=\"\"')")
    for name in _ros_option(argv, ("--params-file",)):
        if not name:
            raise ParameterError("--params-file needs a file name")
        path = Path(name)
        try:
            text = path.read_text()
        except FileNotFoundError:
            raise ParameterError(f"--params-file {name}: no such file") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise ParameterError(f"--params-file {name}: cannot be read ({exc})") from None
        try:
            doc = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
            problem = getattr(exc, "problem", None) or str(exc).split("\n")[0]
            raise ParameterError(f"--params-file {name} is not valid YAML: {where}{problem}") from None
        if not isinstance(doc, dict) or not all(
                isinstance(v, dict) and isinstance(v.get("ros__parameters", {}), dict) for v in doc.values()):
            raise ParameterError(f"--params-file {name} must map node names (or /**) to "
                                 "{ros__parameters: {name: value, ...}}")


def _one_line(exc: BaseException) -> str:
    """rcl's error text without its ', at ./src/...' source locations, on one line."""
    text = " ".join(str(exc).split())
    return text.split(", at ")[0]


def _error(name: str, text: str) -> int:
    print(f"{name}: error: {text}", file=sys.stderr, flush=True)
    return 2


def default_usage(name: str, factory: Callable) -> str:
    """`<name> --help` for a node without its own usage text: the module's summary line."""
    module = sys.modules.get(getattr(factory, "__module__", ""), None)
    doc = ((module.__doc__ if module else None) or "").strip().splitlines()
    return "\n".join([f"usage: {name} [--help]", f"       {name} --ros-args [--params-file FILE] "
                      "[-p name:=value ...]", "", *(doc[:1] or [f"Runs the {name} node."]),
                      "Parameters: `ros2 param describe` on the running node; see docs/."])


class _OneInterrupt:
    """Python's SIGINT handler while the node runs (rclpy's handler chains to it): the first SIGINT
    raises KeyboardInterrupt to stop the start-up, later ones are ignored so that they cannot interrupt
    the shutdown that the first one started. Inside `held_back()` a SIGINT is only noted, and raised when
    the block ends. Once `spinning`, a SIGINT raises nothing: rclpy's handler has shut the context down,
    and `spin` leaves with ExternalShutdownException at a point of its choosing. A KeyboardInterrupt
    raised anywhere in `spin` could land inside rclpy's `Task.__init__` before its `Future` fields are
    set, and `Future.__del__` then printed "AttributeError: 'Task' object has no attribute '_exception'"
    on the way out (seen once in test_hardening_shutdown)."""

    def __init__(self) -> None:
        self.seen = False
        self.held = 0
        self.pending = False
        self.spinning = False

    def __call__(self, _signum: int, _frame: object) -> None:
        if self.held:
            self.pending = True
            return
        if not self.seen:
            self.seen = True
            if not self.spinning:
                raise KeyboardInterrupt

    @contextlib.contextmanager
    def held_back(self):
        self.held += 1
        try:
            yield
        finally:
            self.held -= 1
        if not self.held and self.pending:
            self.pending = False
            self(signal.SIGINT, None)


@contextlib.contextmanager
def signals_deferred():
    """Hold a SIGINT back while the block runs; it takes effect when the block ends.

    For start-up work that runs Python code inside C callbacks (numba loading its compiled loops calls back
    through ctypes): a KeyboardInterrupt raised there is swallowed by ctypes ("Exception ignored on calling
    ctypes callback function") instead of stopping the node. Masking the signal would not do: the DDS
    threads still receive it and Python runs the handler in the main thread wherever it is. SIGTERM needs
    nothing: rclpy's handler shuts the context down without raising."""
    handler = signal.getsignal(signal.SIGINT)
    if isinstance(handler, _OneInterrupt):
        with handler.held_back():
            yield
    else:
        yield


def _ignore_signals() -> None:
    """From the first signal on, ignore SIGINT / SIGTERM for the rest of the shutdown: a second SIGINT
    (a terminal's Ctrl-C plus `ros2 launch`'s own) must not interrupt `before_destroy` / `destroy_node`
    with a KeyboardInterrupt, nor kill the interpreter while it finalises (exit -2)."""
    while True:
        try:
            with contextlib.suppress(Exception):
                rclpy.signals.uninstall_signal_handlers()  # it would restore Python's handlers later
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
            return
        except KeyboardInterrupt:  # the second signal arrived before the first ignore took effect
            continue


def run_node(
    name: str,
    factory: Callable[[], N],
    argv: list[str] | None = None,
    *,
    startup_errors: tuple[type[Exception], ...] = (ParameterError,),
    before_destroy: Callable[[N], None] | None = None,
    usage: Callable[[], str] | None = None,
) -> int:
    """Run one node until SIGINT/SIGTERM and return the process exit code.

    0 after `--help` (usage printed, ROS never initialised) and after a signal; 2 when the ROS arguments
    or a params file are unusable, or building the node raises one of `startup_errors` (a bad parameter,
    an invalid topic name, a missing model), printed as one line. A signal that arrives while the node is
    still being built also gives 0. Any other exception propagates, after `before_destroy(node)` (e.g.
    the positioner's final stop), `destroy_node()` and `rclpy.try_shutdown()` have run.
    """
    args = list(sys.argv if argv is None else argv)
    if any(a in HELP_FLAGS for a in user_arguments(args)):
        print(usage() if usage is not None else default_usage(name, factory))
        return 0
    interrupt = _OneInterrupt()
    signal.signal(signal.SIGINT, interrupt)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # rclpy's handler chains to a non-default one
    try:
        check_ros_args(args)
        rclpy.init(args=args)
    except KeyboardInterrupt:
        _ignore_signals()
        rclpy.try_shutdown()
        return 0
    except ParameterError as exc:
        return _error(name, str(exc))
    except (rclpy._rclpy_pybind11.RCLError, ValueError) as exc:  # RCLInvalidROSArgsError is an RCLError
        return _error(name, f"bad ROS arguments: {_one_line(exc)}")
    try:
        node = factory()
    except (*startup_errors, NameValidationException) as exc:
        rclpy.logging.get_logger(name).error(f"cannot start: {_one_line(exc)}")
        rclpy.try_shutdown()
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        _ignore_signals()
        rclpy.try_shutdown()
        return 0
    except Exception:
        if rclpy.ok():
            rclpy.try_shutdown()
            raise
        _ignore_signals()
        return 0  # the signal's shutdown invalidated the context while the node was being built
    interrupt.spinning = True
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if node.context.ok():
            raise  # a real failure; after a signal, spin may fail on the invalidated context instead
    finally:
        _ignore_signals()
        if before_destroy is not None:
            before_destroy(node)
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
