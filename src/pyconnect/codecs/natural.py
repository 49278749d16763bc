"""The table of natural codecs (docs/design.md §4): which type gets which codec, on first use."""

from __future__ import annotations

_C = "pyconnect.codecs"

# "pkg/msg/Name" -> "module:factory". The factory takes no arguments and returns a Codec.
# Importing lazily keeps `import pyconnect.codecs` free of numpy/OpenCV until a codec is used.
NATURAL_CODECS: dict[str, str] = {
    # sensor_msgs
    "sensor_msgs/msg/Image": f"{_C}.image:ImageCodec",
    "sensor_msgs/msg/CompressedImage": f"{_C}.compressed_image:CompressedImageCodec",
    "sensor_msgs/msg/PointCloud2": f"{_C}.point_cloud:PointCloudCodec",
    "sensor_msgs/msg/LaserScan": f"{_C}.laser_scan:LaserScanCodec",
    "sensor_msgs/msg/JointState": f"{_C}.joint_state:JointStateCodec",
    # nav_msgs
    "nav_msgs/msg/OccupancyGrid": f"{_C}.occupancy_grid:OccupancyGridCodec",
    "nav_msgs/msg/Path": f"{_C}.geometry_arrays:PathCodec",
    # geometry_msgs
    "geometry_msgs/msg/Vector3": f"{_C}.geometry:Vector3Codec",
    "geometry_msgs/msg/Point": f"{_C}.geometry:PointCodec",
    "geometry_msgs/msg/Point32": f"{_C}.geometry:Point32Codec",
    "geometry_msgs/msg/Quaternion": f"{_C}.geometry:QuaternionCodec",
    "geometry_msgs/msg/Pose2D": f"{_C}.geometry:Pose2DCodec",
    "geometry_msgs/msg/Pose": f"{_C}.geometry:PoseCodec",
    "geometry_msgs/msg/Transform": f"{_C}.geometry:TransformCodec",
    "geometry_msgs/msg/Twist": f"{_C}.geometry_twist:TwistCodec",
    "geometry_msgs/msg/Accel": f"{_C}.geometry_twist:AccelCodec",
    "geometry_msgs/msg/Wrench": f"{_C}.geometry_twist:WrenchCodec",
    "geometry_msgs/msg/Polygon": f"{_C}.geometry_arrays:PolygonCodec",
    "geometry_msgs/msg/PoseArray": f"{_C}.geometry_arrays:PoseArrayCodec",
    "geometry_msgs/msg/PointStamped": f"{_C}.geometry_stamped:point_stamped_codec",
    "geometry_msgs/msg/Vector3Stamped": f"{_C}.geometry_stamped:vector3_stamped_codec",
    "geometry_msgs/msg/QuaternionStamped": f"{_C}.geometry_stamped:quaternion_stamped_codec",
    "geometry_msgs/msg/PoseStamped": f"{_C}.geometry_stamped:pose_stamped_codec",
    "geometry_msgs/msg/TransformStamped": f"{_C}.geometry_stamped:transform_stamped_codec",
    "geometry_msgs/msg/TwistStamped": f"{_C}.geometry_stamped:twist_stamped_codec",
    "geometry_msgs/msg/AccelStamped": f"{_C}.geometry_stamped:accel_stamped_codec",
    "geometry_msgs/msg/WrenchStamped": f"{_C}.geometry_stamped:wrench_stamped_codec",
    "geometry_msgs/msg/PolygonStamped": f"{_C}.geometry_stamped:polygon_stamped_codec",
    # std_msgs
    "std_msgs/msg/Bool": f"{_C}.std_scalars:BoolCodec",
    "std_msgs/msg/Byte": f"{_C}.std_scalars:ByteCodec",
    "std_msgs/msg/Char": f"{_C}.std_scalars:char_codec",
    "std_msgs/msg/Int8": f"{_C}.std_scalars:int8_codec",
    "std_msgs/msg/Int16": f"{_C}.std_scalars:int16_codec",
    "std_msgs/msg/Int32": f"{_C}.std_scalars:int32_codec",
    "std_msgs/msg/Int64": f"{_C}.std_scalars:int64_codec",
    "std_msgs/msg/UInt8": f"{_C}.std_scalars:uint8_codec",
    "std_msgs/msg/UInt16": f"{_C}.std_scalars:uint16_codec",
    "std_msgs/msg/UInt32": f"{_C}.std_scalars:uint32_codec",
    "std_msgs/msg/UInt64": f"{_C}.std_scalars:uint64_codec",
    "std_msgs/msg/Float32": f"{_C}.std_scalars:float32_codec",
    "std_msgs/msg/Float64": f"{_C}.std_scalars:float64_codec",
    "std_msgs/msg/String": f"{_C}.std_scalars:StringCodec",
    "std_msgs/msg/Empty": f"{_C}.std_scalars:EmptyCodec",
    "std_msgs/msg/ColorRGBA": f"{_C}.std_scalars:ColorRGBACodec",
    "std_msgs/msg/ByteMultiArray": f"{_C}.multi_array:byte_multi_array_codec",
    "std_msgs/msg/Int8MultiArray": f"{_C}.multi_array:int8_multi_array_codec",
    "std_msgs/msg/UInt8MultiArray": f"{_C}.multi_array:uint8_multi_array_codec",
    "std_msgs/msg/Int16MultiArray": f"{_C}.multi_array:int16_multi_array_codec",
    "std_msgs/msg/UInt16MultiArray": f"{_C}.multi_array:uint16_multi_array_codec",
    "std_msgs/msg/Int32MultiArray": f"{_C}.multi_array:int32_multi_array_codec",
    "std_msgs/msg/UInt32MultiArray": f"{_C}.multi_array:uint32_multi_array_codec",
    "std_msgs/msg/Int64MultiArray": f"{_C}.multi_array:int64_multi_array_codec",
    "std_msgs/msg/UInt64MultiArray": f"{_C}.multi_array:uint64_multi_array_codec",
    "std_msgs/msg/Float32MultiArray": f"{_C}.multi_array:float32_multi_array_codec",
    "std_msgs/msg/Float64MultiArray": f"{_C}.multi_array:float64_multi_array_codec",
    # builtin_interfaces
    "builtin_interfaces/msg/Time": f"{_C}.builtin_time:TimeCodec",
    "builtin_interfaces/msg/Duration": f"{_C}.builtin_time:DurationCodec",
}
