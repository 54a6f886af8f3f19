function(ips_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wold-style-cast -Wcast-align -Woverloaded-virtual
                                           -Wnull-dereference -Wimplicit-fallthrough)
  # GCC 12 reports -Warray-bounds / -Wstringop-overflow / -Wstringop-overread false positives
  # inside libstdc++'s inlined std::string copies (GCC PR 105651, 105329), more of them once
  # headers are precompiled. Out-of-bounds accesses are still
  # caught at run time by the ASan + UBSan configuration, built with clang, which keeps the warning.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-array-bounds -Wno-stringop-overflow -Wno-stringop-overread)
  endif()
endfunction()
