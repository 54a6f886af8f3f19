# CPACK_POST_BUILD_SCRIPTS (cmake/Install.cmake): makes the ipsd-dbgsym .ddeb CPack 3.25 writes
# what dh_strip would have written. CPack lists the .debug files in its md5sums by their paths in
# the staging tree (/.../_CPack_Packages/.../usr/lib/debug/...; lintian: md5sums-lists-
# nonexistent-file) and gives the package no copyright or changelog. Here the .ddeb is unpacked,
# its md5sums rewritten with package paths, the .debug files made 0644, and
# /usr/share/doc/ipsd-dbgsym linked to ipsd's directory (copyright, changelog; the .ddeb depends
# on the same version of ipsd), then packed again.
foreach(pkg IN LISTS CPACK_PACKAGE_FILES)
  if(NOT pkg MATCHES "-dbgsym_[^/]*\\.ddeb$")
    continue()
  endif()
  set(root "${pkg}.root")
  file(REMOVE_RECURSE "${root}")
  execute_process(COMMAND dpkg-deb -R "${pkg}" "${root}" COMMAND_ERROR_IS_FATAL ANY)
  file(GLOB_RECURSE debug_files LIST_DIRECTORIES false RELATIVE "${root}" "${root}/usr/*")
  list(SORT debug_files)
  set(md5sums "")
  foreach(f IN LISTS debug_files)
    file(MD5 "${root}/${f}" sum)
    string(APPEND md5sums "${sum}  ${f}\n")
    file(CHMOD "${root}/${f}" PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ)
  endforeach()
  file(WRITE "${root}/DEBIAN/md5sums" "${md5sums}")
  file(MAKE_DIRECTORY "${root}/usr/share/doc")
  file(CREATE_LINK ipsd "${root}/usr/share/doc/ipsd-dbgsym" SYMBOLIC)
  execute_process(COMMAND dpkg-deb --root-owner-group --build "${root}" "${pkg}"
                  OUTPUT_QUIET COMMAND_ERROR_IS_FATAL ANY)
  file(REMOVE_RECURSE "${root}")
endforeach()
