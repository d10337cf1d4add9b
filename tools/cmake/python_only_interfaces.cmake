# tools/setup.sh passes this file to every CMake package of ros_ws as CMAKE_PROJECT_INCLUDE (CMake
# includes it at the end of the package's project() call). With FEEDER_PYTHON_ONLY_INTERFACES ON (the
# setup's default) a package's rosidl_generate_interfaces() runs only the generators the project's
# Python nodes use: rosidl_generator_c and _py, the C typesupports (rosidl_typesupport_c, _fastrtps_c,
# which rmw_fastrtps_cpp loads, _introspection_c) and the type descriptions (the RIHS01 hashes). The C++
# headers and C++ typesupports (rosidl_generator_cpp, rosidl_typesupport_cpp, _fastrtps_cpp,
# _introspection_cpp), which only C++ nodes use, are not generated; they were half of the build's CPU.
# The project has no C++ nodes. OFF (FEEDER_CXX_INTERFACES=1 make setup), or a plain `colcon build`
# on a full ROS 2 install, which does not include this file, generates them all.
#
# How: the generators register themselves for the "rosidl_generate_idl_interfaces" extension point
# when rosidl_default_generators is found, and ament includes a package's config only once per
# directory. Found here first, the C++ generators are dropped from the list before the package's own
# find_package(rosidl_default_generators) (a no-op then) and rosidl_generate_interfaces() run.
option(FEEDER_PYTHON_ONLY_INTERFACES "Generate only the C/Python interface code the Python nodes use" OFF)
if(FEEDER_PYTHON_ONLY_INTERFACES)
  find_package(rosidl_default_generators QUIET)
  if(rosidl_default_generators_FOUND)
    list(FILTER AMENT_EXTENSIONS_rosidl_generate_idl_interfaces EXCLUDE REGEX
      "^rosidl_(generator_cpp|typesupport_cpp|typesupport_fastrtps_cpp|typesupport_introspection_cpp):")
    message(STATUS "FEEDER_PYTHON_ONLY_INTERFACES: rosidl generators "
      "${AMENT_EXTENSIONS_rosidl_generate_idl_interfaces}")
  endif()
endif()
