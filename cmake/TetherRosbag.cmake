# ROS 1 bag reading through Debian's librosbag-storage-dev, libsensor-msgs-dev and
# libnav-msgs-dev. Debian ships no usable CMake or pkg-config entry for them (rosbag_storage.pc
# requires a pluginlib.pc that does not exist, and its headers include pluginlib's, which live
# one folder deeper under ROS 2's layout), so the headers and libraries are found one by one.
# Defines TetherRosbag_FOUND and the imported target tether_rosbag_deps.
set(TetherRosbag_FOUND FALSE)
find_path(TETHER_ROSBAG_INCLUDE_DIR rosbag/bag.h)
find_path(TETHER_SENSOR_MSGS_INCLUDE_DIR sensor_msgs/LaserScan.h)
find_path(TETHER_NAV_MSGS_INCLUDE_DIR nav_msgs/Odometry.h)
# rosbag/bag.h -> pluginlib/class_loader.hpp -> class_loader, rcpputils, rcutils, ament_index_cpp
set(_tether_rosbag_include_vars)
foreach(_h pluginlib/class_loader.hpp class_loader/multi_library_class_loader.hpp rcpputils/shared_library.hpp
           rcutils/shared_library.h ament_index_cpp/get_package_prefix.hpp)
  string(REGEX REPLACE "[/.]" "_" _v "TETHER_ROSBAG_${_h}")
  string(REGEX REPLACE "/.*" "" _suffix "${_h}")
  find_path(${_v} ${_h} PATH_SUFFIXES ${_suffix})
  list(APPEND _tether_rosbag_include_vars ${_v})
endforeach()
set(_tether_rosbag_library_vars)
foreach(_l rosbag_storage roscpp_serialization rostime cpp_common console_bridge)
  find_library(TETHER_ROSBAG_LIB_${_l} ${_l})
  list(APPEND _tether_rosbag_library_vars TETHER_ROSBAG_LIB_${_l})
endforeach()
set(_tether_rosbag_ok TRUE)
foreach(_v TETHER_ROSBAG_INCLUDE_DIR TETHER_SENSOR_MSGS_INCLUDE_DIR TETHER_NAV_MSGS_INCLUDE_DIR
           ${_tether_rosbag_include_vars} ${_tether_rosbag_library_vars})
  if(NOT ${_v})
    set(_tether_rosbag_ok FALSE)
    set(TetherRosbag_MISSING "${_v}")
  endif()
endforeach()
if(_tether_rosbag_ok)
  set(TetherRosbag_FOUND TRUE)
  if(NOT TARGET tether_rosbag_deps)
    add_library(tether_rosbag_deps INTERFACE IMPORTED)
    set(_dirs ${TETHER_ROSBAG_INCLUDE_DIR} ${TETHER_SENSOR_MSGS_INCLUDE_DIR} ${TETHER_NAV_MSGS_INCLUDE_DIR})
    foreach(_v ${_tether_rosbag_include_vars})
      list(APPEND _dirs ${${_v}})
    endforeach()
    list(REMOVE_DUPLICATES _dirs)
    set(_libs)
    foreach(_v ${_tether_rosbag_library_vars})
      list(APPEND _libs ${${_v}})
    endforeach()
    set_target_properties(tether_rosbag_deps PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_dirs}"
                                                        INTERFACE_LINK_LIBRARIES "${_libs}")
  endif()
endif()
