"""Running vibration nodes: one node until SIGINT/SIGTERM (``bkabem node``), and the exit statistics line that
tools parse (docs/contract.md)."""

from __future__ import annotations

from collections.abc import Callable

from bkabem_ros.node.vibration_node import VibrationNode

__all__ = ["run", "exit_log", "quiet_gc"]


def _stats_line(st: dict) -> str:
    return (f"stats: {st['chunks']} chunks (next index {st['next_index']}), {st['spectra']} spectra, "
            f"{st['speed_messages']} speed messages ({st['speed_rejected']} rejected), publish lateness "
            f"p50 {st['lateness_ms_p50']:.3f} ms p99 {st['lateness_ms_p99']:.3f} ms max {st['lateness_ms_max']:.3f} ms "
            f"at chunk {st['lateness_max_chunk']}, {st['late_chunks']} a period late "
            f"(start p50 {st['start_lateness_ms_p50']:.3f} ms p99 {st['start_lateness_ms_p99']:.3f} ms)")


def quiet_gc() -> None:
    """After start-up: move everything allocated so far (model, modules) out of the collector's view, so that
    a full collection during streaming scans only what the stream allocates (shorter pauses, less jitter)."""
    import gc

    gc.collect()
    gc.freeze()


def exit_log(node, st: dict | None = None) -> None:
    """Final stats line. Not through the node's logger: after SIGINT/SIGTERM rclpy has already shut the
    context down, and a node logger would try (and fail) to publish on /rosout."""
    import rclpy.logging

    st = node.stats() if st is None else st
    rclpy.logging.get_logger("bkabem_exit").info(
        f"{node.get_fully_qualified_name()} ({st['machine_id']}) shutting down: {_stats_line(st)}")


def run(ros_args=None, overrides: dict | None = None, *, node_name: str = "bkabem", namespace: str | None = None,
        on_node: Callable | None = None) -> int:
    """Run one node until SIGINT/SIGTERM; returns the exit code (2 for bad parameters or case)."""
    import sys

    import rclpy
    from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from bkabem_core.model.case import CaseError
    from bkabem_ros.ros_env import announce, init, until_stopped  # noqa: PLC0415

    # the discovery range is announced once the node took its parameters: a refused parameter, case or label is then
    # the one line of the command (the node has joined the graph for that second, but sends nothing)
    init(["bkabem-node", "--ros-args", *(ros_args or [])], announce_now=False)
    node = None
    cleanup = None
    try:
        try:
            node = VibrationNode(node_name, namespace=namespace,
                                 parameter_overrides=[Parameter(k, value=v) for k, v in (overrides or {}).items()],
                                 start=False)
        except (CaseError, InvalidParameterValueException, InvalidParameterTypeException, ValueError) as exc:
            sys.stderr.write(f"bkabem node: error: {' '.join(str(exc).split())}\n")
            return 2
        if on_node is not None:                 # its sinks (a recording that cannot start: one line, no banner)
            cleanup = on_node(node)
        announce()
        quiet_gc()
        node.start()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        with until_stopped():
            executor.spin()
        exit_log(node)
        return 0
    finally:
        if cleanup is not None:
            cleanup()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
