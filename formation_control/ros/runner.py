"""The main loop every node shares: spin_once until done or shut down, exit 0 on SIGINT."""
import sys

import rclpy
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from formation_control.core.scenario import ScenarioError


def run(make_node, args=None):
    """Create the node with ``make_node(context)``; a bad scenario exits 2 with the reason."""
    rclpy.init(args=args)
    context = rclpy.get_default_context()
    node = None
    try:
        node = make_node(context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        while context.ok() and not getattr(node, 'done', False):
            executor.spin_once(timeout_sec=0.1)
    except (ScenarioError, InvalidParameterTypeException, InvalidParameterValueException) as err:
        print(f'error: {err}', file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
