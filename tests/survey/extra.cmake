# The survey's end-to-end test runs `ips record`, `ips survey` and `ips sim collect`, with the
# daemon tests' process helpers (tests/daemon/process_util.h).
if(TARGET test_survey)
  target_include_directories(test_survey PRIVATE ${CMAKE_CURRENT_LIST_DIR}/../daemon)
  add_dependencies(test_survey ips_tool)
endif()
