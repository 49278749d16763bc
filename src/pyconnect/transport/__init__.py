"""Non-ROS peers over zenoh, on rmw_zenoh's wire: ``from pyconnect.transport import Peer``.

Needs the ``zenoh`` extra (``pip install 'pyconnect[zenoh]'``); imports no rclpy.
"""

from pyconnect.transport.peer import Peer
from pyconnect.transport.router import start_router

__all__ = ["Peer", "start_router"]
