#pragma once
// Compile-time table: C message struct -> DDS topic descriptor and ROS type
// name.
#include <string_view>

#include <dds/dds.h>

#include "regolith/msgs/types.hpp"

namespace regolith::dds {

template <class Msg>
struct MsgTraits;  // specialised below for every type of regolith::msgs

#define REGOLITH_DDS_MSG_TRAITS(pkg, Type)                                                         \
  template <>                                                                                      \
  struct MsgTraits<::pkg##_msg_dds__##Type##_> {                                                   \
    static const dds_topic_descriptor_t* descriptor() { return &::pkg##_msg_dds__##Type##__desc; } \
    static constexpr std::string_view ros_type = #pkg "/msg/" #Type;                               \
  };
REGOLITH_DDS_MSG_TRAITS(builtin_interfaces, Time)
REGOLITH_DDS_MSG_TRAITS(std_msgs, Header)
REGOLITH_DDS_MSG_TRAITS(std_msgs, MultiArrayDimension)
REGOLITH_DDS_MSG_TRAITS(std_msgs, MultiArrayLayout)
REGOLITH_DDS_MSG_TRAITS(std_msgs, Float32MultiArray)
REGOLITH_DDS_MSG_TRAITS(geometry_msgs, Point)
REGOLITH_DDS_MSG_TRAITS(geometry_msgs, Quaternion)
REGOLITH_DDS_MSG_TRAITS(geometry_msgs, Pose)
REGOLITH_DDS_MSG_TRAITS(geometry_msgs, Pose2D)
REGOLITH_DDS_MSG_TRAITS(geometry_msgs, PoseWithCovariance)
REGOLITH_DDS_MSG_TRAITS(geometry_msgs, Twist)
REGOLITH_DDS_MSG_TRAITS(geometry_msgs, TwistWithCovariance)
REGOLITH_DDS_MSG_TRAITS(geometry_msgs, Transform)
REGOLITH_DDS_MSG_TRAITS(geometry_msgs, TransformStamped)
REGOLITH_DDS_MSG_TRAITS(tf2_msgs, TFMessage)
REGOLITH_DDS_MSG_TRAITS(rosgraph_msgs, Clock)
REGOLITH_DDS_MSG_TRAITS(rcl_interfaces, Log)
REGOLITH_DDS_MSG_TRAITS(rmw_dds_common, ParticipantEntitiesInfo)
REGOLITH_DDS_MSG_TRAITS(nav_msgs, Odometry)
REGOLITH_DDS_MSG_TRAITS(sensor_msgs, JointState)
REGOLITH_DDS_MSG_TRAITS(sensor_msgs, Imu)
REGOLITH_DDS_MSG_TRAITS(sensor_msgs, CompressedImage)
REGOLITH_DDS_MSG_TRAITS(geometry_msgs, Vector3)
REGOLITH_DDS_MSG_TRAITS(diagnostic_msgs, KeyValue)
REGOLITH_DDS_MSG_TRAITS(diagnostic_msgs, DiagnosticStatus)
REGOLITH_DDS_MSG_TRAITS(diagnostic_msgs, DiagnosticArray)
REGOLITH_DDS_MSG_TRAITS(grid_map_msgs, GridMapInfo)
REGOLITH_DDS_MSG_TRAITS(grid_map_msgs, GridMap)
REGOLITH_DDS_MSG_TRAITS(vision_msgs, Point2D)
REGOLITH_DDS_MSG_TRAITS(vision_msgs, Pose2D)
REGOLITH_DDS_MSG_TRAITS(vision_msgs, BoundingBox2D)
REGOLITH_DDS_MSG_TRAITS(vision_msgs, ObjectHypothesis)
REGOLITH_DDS_MSG_TRAITS(vision_msgs, ObjectHypothesisWithPose)
REGOLITH_DDS_MSG_TRAITS(vision_msgs, Detection2D)
REGOLITH_DDS_MSG_TRAITS(vision_msgs, Detection2DArray)
REGOLITH_DDS_MSG_TRAITS(vision_msgs, BoundingBox3D)
REGOLITH_DDS_MSG_TRAITS(vision_msgs, Detection3D)
REGOLITH_DDS_MSG_TRAITS(vision_msgs, Detection3DArray)
REGOLITH_DDS_MSG_TRAITS(regolith_msgs, WheelSinkage)
REGOLITH_DDS_MSG_TRAITS(regolith_msgs, SoilStiffness)
REGOLITH_DDS_MSG_TRAITS(regolith_msgs, RockArray)
#undef REGOLITH_DDS_MSG_TRAITS

}  // namespace regolith::dds
