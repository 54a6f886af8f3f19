function(ips_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wold-style-cast -Wcast-align -Woverloaded-virtual
                                           -Wnull-dereference -Wimplicit-fallthrough)
  # GCC 12 reports -Warray-bounds / -Wstringop-overflow / -Wstringop-overread / -Wrestrict false positives
  # inside libstdc++'s inlined std::string copies (GCC PR 105651, 105329), more of them once
  # headers are precompiled. Out-of-bounds accesses are still
  # caught at run time by the ASan + UBSan configuration, built with clang, which keeps the warning.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-array-bounds -Wno-stringop-overflow -Wno-stringop-overread
                                             -Wno-restrict)
  endif()
  # In a unity batch a file's private Impl (defined in the .cpp, holding a type of the file's
  # anonymous namespace) is no longer in "the main file", and GCC warns that its field's type has
  # internal linkage. True of any pimpl; nothing is shared across batches.
  if((IPS_UNITY_BUILD OR IPS_UNITY_PROGRAMS) AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -Wno-subobject-linkage)
  endif()
endfunction()
