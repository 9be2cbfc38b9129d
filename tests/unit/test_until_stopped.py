"""The one stop rule of every spin loop (bkabem_ros.ros_env.until_stopped): an error raised once the context is shut
down is the stop asked for; with the context valid it is a real error. A real rclpy context, no node, no DDS."""
import pytest
import rclpy

from bkabem_ros.ros_env import until_stopped


@pytest.fixture
def context():
    ctx = rclpy.Context()
    rclpy.init(args=[], context=ctx)
    yield ctx
    rclpy.try_shutdown(context=ctx)


def test_an_error_while_the_context_is_valid_propagates(context):
    with pytest.raises(RuntimeError, match="real"):
        with until_stopped(context):
            raise RuntimeError("real")


def test_an_error_after_the_shutdown_is_the_stop(context):
    ran_after = []
    with until_stopped(context):
        rclpy.shutdown(context=context)       # what rclpy's SIGINT handler does before KeyboardInterrupt arrives
        # the error seen in CI from a subscription's take in that moment
        raise RuntimeError("Unable to convert call argument '0' to Python object")
    ran_after.append(True)
    assert ran_after == [True]


def test_keyboard_interrupt_ends_the_block_quietly(context):
    with until_stopped(context):
        raise KeyboardInterrupt


@pytest.mark.parametrize("form", ["keyboard", "error_after_shutdown", "external"])
def test_interrupt_true_surfaces_every_form_of_the_stop_as_keyboard_interrupt(context, form):
    from rclpy.executors import ExternalShutdownException

    with pytest.raises(KeyboardInterrupt):
        with until_stopped(context, interrupt=True):
            if form == "keyboard":
                raise KeyboardInterrupt
            if form == "external":
                raise ExternalShutdownException()
            rclpy.shutdown(context=context)
            raise RuntimeError("publisher's context is invalid")


def test_interrupt_true_keeps_a_real_error(context):
    with pytest.raises(ValueError):
        with until_stopped(context, interrupt=True):
            raise ValueError("real")


def test_a_normal_end_passes_through(context):
    with until_stopped(context):
        x = 1
    assert x == 1
