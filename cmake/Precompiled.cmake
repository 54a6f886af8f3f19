# Precompiled headers: the headers almost every translation unit parses (the standard library,
# OpenCV core, Eigen, nlohmann::json, spdlog; GoogleTest for the tests, CLI11 for the programs).
# Parsing them took ~5 s of the ~12 s a test file costs on CI's two cores. One PCH per kind of
# target is built by a small owner target and reused by every target of that kind (REUSE_FROM
# needs identical flags: the owner takes them from the same interface target as its users, and
# being a one-file object library, it does not make its users wait for anything else).
set(IPS_PCH_COMMON
  <algorithm> <array> <chrono> <cmath> <cstdint> <cstdio> <cstring> <filesystem> <fstream>
  <map> <memory> <optional> <set> <sstream> <string> <vector>
  <Eigen/Core> <opencv2/core.hpp> <opencv2/imgproc.hpp> <nlohmann/json.hpp> <spdlog/spdlog.h>)

option(IPS_PRECOMPILE_HEADERS "Use precompiled headers (faster clean builds)" ON)

# ips_pch_owner(<name> <flags_target> <extra headers>...): an object library compiling the PCH
# with the flags of <flags_target> (an INTERFACE library the users also link).
function(ips_pch_owner name flags_target)
  if(NOT IPS_PRECOMPILE_HEADERS)
    return()
  endif()
  set(headers ${IPS_PCH_COMMON} ${ARGN})
  list(TRANSFORM headers PREPEND "$<$<COMPILE_LANGUAGE:CXX>:")
  list(TRANSFORM headers APPEND ">")
  add_library(${name} OBJECT ${PROJECT_SOURCE_DIR}/cmake/pch_owner.cpp)
  target_link_libraries(${name} PRIVATE ${flags_target})
  ips_set_warnings(${name})
  target_precompile_headers(${name} PRIVATE ${headers})
endfunction()

# ips_precompile(<target> <owner>): use the owner's PCH.
function(ips_precompile target owner)
  if(IPS_PRECOMPILE_HEADERS)
    target_precompile_headers(${target} REUSE_FROM ${owner})
  endif()
endfunction()
