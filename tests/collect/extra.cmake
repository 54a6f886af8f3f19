# The collect tests run `ips collect`, `ips fit` and ipsd, and use the daemon tests' process
# helpers (tests/daemon/process_util.h).
if(TARGET test_collect)
  target_include_directories(test_collect PRIVATE ${CMAKE_CURRENT_LIST_DIR}/../daemon)
  add_dependencies(test_collect ips_tool)
  if(TARGET ipsd)
    add_dependencies(test_collect ipsd)
  endif()
endif()
