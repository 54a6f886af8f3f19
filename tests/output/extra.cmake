# include/ips/output/wire.h must stay plain C99 for robot firmware: compile a C user of it with
# every warning as an error (no C++ in sight).
add_library(ips_wire_c_check OBJECT ${CMAKE_CURRENT_LIST_DIR}/wire_c_check.c)
set_target_properties(ips_wire_c_check PROPERTIES C_STANDARD 99 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF)
target_include_directories(ips_wire_c_check PRIVATE ${PROJECT_SOURCE_DIR}/include)
target_compile_options(ips_wire_c_check PRIVATE -Wall -Wextra -Wpedantic -Werror -Wconversion)
if(TARGET test_output)
  add_dependencies(test_output ips_wire_c_check)
endif()

# The ros2 output's tests subscribe with the Cyclone DDS C API and the generated ROS 2 types.
if(TARGET test_output)
  target_link_libraries(test_output PRIVATE ips_ros2_msgs)
  target_include_directories(test_output PRIVATE ${PROJECT_SOURCE_DIR}/src ${PROJECT_SOURCE_DIR}/tests/daemon)
endif()
