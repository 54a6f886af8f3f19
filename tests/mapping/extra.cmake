# cli_test.cpp runs the built `ips` binary: build it before the test binary.
if(TARGET test_mapping AND TARGET ips_tool)
  add_dependencies(test_mapping ips_tool)
endif()
