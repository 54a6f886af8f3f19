# The .deb installed for real (root only; skipped otherwise). Release configuration only: the
# package is built from release programs, and one install/remove cycle per CI run is enough.
# RUN_SERIAL: it installs into the machine's /usr and /etc.
if(NOT IPS_SANITIZE)
  add_test(NAME package_deb
           COMMAND bash ${CMAKE_CURRENT_LIST_DIR}/package_test.sh ${PROJECT_BINARY_DIR} ${PROJECT_SOURCE_DIR})
  set_tests_properties(package_deb PROPERTIES RUN_SERIAL TRUE SKIP_RETURN_CODE 77 TIMEOUT 600)
endif()
