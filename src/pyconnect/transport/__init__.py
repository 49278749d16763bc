"""Non-ROS peers (TCP links) that carry the same codecs: planned in the design, not built yet.

The wire codecs (``pyconnect.codecs.wire``) are the piece such a transport needs: CDR bytes to
natural values and back with no rclpy. No transport issue is open, so nothing lives here yet.
"""
