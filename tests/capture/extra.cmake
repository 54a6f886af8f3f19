# The emulated V4L2 device (an LD_PRELOAD library) and the small program the capture
# tests run under it. The emulator is built without sanitizers even in the ASan build:
# it is preloaded after libasan and must not compete with its interceptors.
add_library(ips_v4l2_emu SHARED ${CMAKE_CURRENT_LIST_DIR}/v4l2_emulator.cpp)
set_target_properties(ips_v4l2_emu PROPERTIES COMPILE_OPTIONS "" LINK_OPTIONS "")
target_link_libraries(ips_v4l2_emu PRIVATE ${CMAKE_DL_LIBS})
ips_set_warnings(ips_v4l2_emu)

add_executable(v4l2_capture_driver ${CMAKE_CURRENT_LIST_DIR}/capture_driver.cpp)
target_link_libraries(v4l2_capture_driver PRIVATE ips)
ips_set_warnings(v4l2_capture_driver)

if(TARGET test_capture)
  add_dependencies(test_capture ips_v4l2_emu v4l2_capture_driver ips_tool)
  target_compile_definitions(test_capture PRIVATE
    IPS_V4L2_EMU_LIB="$<TARGET_FILE:ips_v4l2_emu>"
    IPS_CAPTURE_DRIVER="$<TARGET_FILE:v4l2_capture_driver>"
    IPS_TOOL="$<TARGET_FILE:ips_tool>")
  if(TARGET ipsd)  # the end-to-end test runs the daemon on emulated cameras
    add_dependencies(test_capture ipsd)
  endif()
endif()
