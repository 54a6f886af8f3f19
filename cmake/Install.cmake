# Installation and the Debian package.
#   cmake --install build/release [--prefix /usr/local]   programs, unit, sysusers.d, example config, docs
#   bash tools/package.sh                                  build/package/ipsd_<version>_<arch>.deb
#                                                          (+ ipsd-dbgsym_<version>_<arch>.ddeb)
#
# The system paths depend on the prefix and are decided at install time (not configure time), so
# the same build tree installs to /usr/local by hand and to /usr for the package without a rebuild:
#   prefix /usr (the package):  /etc/ipsd, /lib/systemd/system (Debian 12 units live under /lib:
#                               dpkg does not know that /lib and /usr/lib are one directory)
#   any other prefix P:         P/etc/ipsd, P/lib/systemd/system (systemd reads /usr/local/lib/...)
# sysusers.d entries always go to PREFIX/lib/sysusers.d (systemd-sysusers reads /usr/lib and
# /usr/local/lib).
include(GNUInstallDirs)

install(CODE [[
  # The package is staged with prefix /usr under DESTDIR; an install by hand has /usr/local or another prefix.
  # IPS_*_DIR are where files go now, IPS_RUN_* the paths the installed unit names.
  if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
    set(IPS_ETC_DIR "/etc/ipsd")
    set(IPS_UNIT_DIR "/lib/systemd/system")
    set(IPS_RUN_PREFIX "/usr")
    set(IPS_RUN_ETC "/etc/ipsd")
  else()
    set(IPS_ETC_DIR "${CMAKE_INSTALL_PREFIX}/etc/ipsd")
    set(IPS_UNIT_DIR "${CMAKE_INSTALL_PREFIX}/lib/systemd/system")
    set(IPS_RUN_PREFIX "${CMAKE_INSTALL_PREFIX}")
    set(IPS_RUN_ETC "${IPS_ETC_DIR}")
  endif()
  # Written below as DESTINATION "/${...}": a destination that is not absolute when CMake generates
  # the install script would be put under the prefix, so these are kept without their leading /.
  string(REGEX REPLACE "^/+" "" IPS_ETC_DIR "${IPS_ETC_DIR}")
  string(REGEX REPLACE "^/+" "" IPS_UNIT_DIR "${IPS_UNIT_DIR}")
  set(IPS_BIN_DIR "${IPS_RUN_PREFIX}/bin")
  set(IPS_DOC_DIR "${IPS_RUN_PREFIX}/share/doc/ipsd")
]])
# The unit names the installed program and config; configured at install time for that reason.
install(CODE "configure_file(\"${PROJECT_SOURCE_DIR}/packaging/ipsd.service.in\" \"${PROJECT_BINARY_DIR}/packaging/ipsd.service\" @ONLY)")

install(TARGETS ips_tool RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
if(TARGET ipsd)
  install(TARGETS ipsd RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()
# The simulated lab from the installed files (examples below), no camera and no build tree.
install(PROGRAMS packaging/ipsd-demo DESTINATION ${CMAKE_INSTALL_BINDIR})
install(FILES ${PROJECT_BINARY_DIR}/packaging/ipsd.service DESTINATION "/\${IPS_UNIT_DIR}")
install(FILES packaging/sysusers.conf DESTINATION lib/sysusers.d RENAME ipsd.conf)
install(FILES config/ipsd.yaml DESTINATION "/\${IPS_ETC_DIR}")
install(FILES README.md packaging/deb/copyright DESTINATION ${CMAKE_INSTALL_DOCDIR})
# The manual beside the README, so that the installed README's links into docs/ resolve.
# (CHANGELOG.md stays in the source tree: lintian warns about an upstream changelog not named
# changelog.gz, and the package keeps to the documented warnings.)
file(GLOB IPS_DOC_PAGES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/docs/*.md ${PROJECT_SOURCE_DIR}/docs/*.png)
install(FILES ${IPS_DOC_PAGES} DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs)
install(FILES tools/ipsd_client.py DESTINATION ${CMAKE_INSTALL_DATADIR}/ipsd
        PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)

# ---------------------------------------------------------------------------
# Example data a new lab can try ipsd with before it has calibrated anything, laid out as in the
# source tree so that every relative path in it resolves where it is installed:
#   DATADIR/ipsd/calib_data/ou2023/       the published intrinsics and calibration pairs
#   DATADIR/ipsd/examples/scenes/         the simulated labs; their `../../calib_data/ou2023/...`
#                                         are the directory above
#   DATADIR/ipsd/examples/demo.yaml       config/demo.yaml naming the model below (model.json)
#   DATADIR/ipsd/examples/model.json      plane model of the simulated published lab, fitted here
install(DIRECTORY calib_data/ou2023 DESTINATION ${CMAKE_INSTALL_DATADIR}/ipsd/calib_data)
install(DIRECTORY config/scenes DESTINATION ${CMAKE_INSTALL_DATADIR}/ipsd/examples)
# The demo's model, fitted at build time the way tools/demo.sh fits it: 40 calibration pairs per
# camera collected in the simulator on the published lab's scene, then `ips fit --method plane`.
set(IPS_EXAMPLES_DIR ${PROJECT_BINARY_DIR}/examples)
add_custom_command(OUTPUT ${IPS_EXAMPLES_DIR}/model.json
  COMMAND ${CMAKE_COMMAND} -E make_directory ${IPS_EXAMPLES_DIR}
  COMMAND $<TARGET_FILE:ips_tool> sim collect --scene ${PROJECT_SOURCE_DIR}/config/scenes/ou2023.yaml
          --points 40 --out ${IPS_EXAMPLES_DIR}/pairs.csv
  COMMAND $<TARGET_FILE:ips_tool> fit --data ${IPS_EXAMPLES_DIR}/pairs.csv --method plane
          --out ${IPS_EXAMPLES_DIR}/model.json
  DEPENDS ips_tool ${PROJECT_SOURCE_DIR}/config/scenes/ou2023.yaml
          ${PROJECT_SOURCE_DIR}/calib_data/ou2023/intrinsics_red.yaml
          ${PROJECT_SOURCE_DIR}/calib_data/ou2023/intrinsics_white.yaml
          ${PROJECT_SOURCE_DIR}/calib_data/ou2023/intrinsics_black.yaml
  COMMENT "Fitting the demo's plane model on simulated calibration pairs (examples/model.json)"
  VERBATIM)
# config/demo.yaml names the model tools/demo.sh writes (../build/demo/model.json); the installed
# copy names the one next to it. Refused (configure error) if that line is not found.
file(READ ${PROJECT_SOURCE_DIR}/config/demo.yaml ips_demo_yaml)
string(REGEX REPLACE "\nmodel_file: [^\n]*\n" "\nmodel_file: model.json\n" ips_demo_installed "${ips_demo_yaml}")
if(ips_demo_installed STREQUAL ips_demo_yaml)
  message(FATAL_ERROR "config/demo.yaml: no top-level 'model_file:' line to point at the installed model")
endif()
file(WRITE ${IPS_EXAMPLES_DIR}/demo.yaml
  "# Installed copy of config/demo.yaml: model.json next to it was fitted when the package was\n"
  "# built. Run it with `ipsd-demo` (writes nothing here).\n${ips_demo_installed}")
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/config/demo.yaml)
add_custom_target(ips_examples ALL DEPENDS ${IPS_EXAMPLES_DIR}/model.json)
install(FILES ${IPS_EXAMPLES_DIR}/demo.yaml ${IPS_EXAMPLES_DIR}/model.json
        DESTINATION ${CMAKE_INSTALL_DATADIR}/ipsd/examples)

# ---------------------------------------------------------------------------
# Man pages of ipsd, ips and ipsd-demo, generated from their --help by help2man (Debian package
# help2man, installed by tools/setup.sh) and installed gzipped. Without help2man they are
# skipped with a note: the programs build and install without them.
find_program(IPS_HELP2MAN help2man)
find_program(IPS_GZIP gzip)
if(IPS_HELP2MAN AND IPS_GZIP AND TARGET ipsd)
  set(IPS_MAN_DIR ${PROJECT_BINARY_DIR}/man)
  set(ips_man_pages)
  foreach(prog ipsd ips ipsd-demo)
    if(prog STREQUAL "ipsd")
      set(exe $<TARGET_FILE:ipsd>)
      set(deps ipsd)
      set(summary "indoor positioning daemon: ceiling cameras, ArUco markers, positions over UDP")
    elseif(prog STREQUAL "ips")
      set(exe $<TARGET_FILE:ips_tool>)
      set(deps ips_tool)
      set(summary "the ipsd toolbox: calibrate, fit camera models, simulate, listen")
    else()
      set(exe ${PROJECT_SOURCE_DIR}/packaging/ipsd-demo)
      set(deps ${exe})
      set(summary "run ipsd on the simulated published lab and show its positions")
    endif()
    add_custom_command(OUTPUT ${IPS_MAN_DIR}/${prog}.1.gz
      COMMAND ${CMAKE_COMMAND} -E make_directory ${IPS_MAN_DIR}
      COMMAND ${IPS_HELP2MAN} --no-info --no-discard-stderr --section=1
              --version-string=${PROJECT_VERSION} --name=${summary}
              --include=${PROJECT_SOURCE_DIR}/packaging/man/see_also.h2m
              --output=${IPS_MAN_DIR}/${prog}.1 ${exe}
      COMMAND ${IPS_GZIP} -9nf ${IPS_MAN_DIR}/${prog}.1
      DEPENDS ${deps} ${PROJECT_SOURCE_DIR}/packaging/man/see_also.h2m
      COMMENT "Man page ${prog}(1) from ${prog} --help (help2man)"
      VERBATIM)
    list(APPEND ips_man_pages ${IPS_MAN_DIR}/${prog}.1.gz)
  endforeach()
  add_custom_target(ips_man ALL DEPENDS ${ips_man_pages})
  install(FILES ${ips_man_pages} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
else()
  message(STATUS "help2man not found: no man pages (bash tools/setup.sh installs it)")
endif()

# ---------------------------------------------------------------------------
# CPack: one .deb, staged under DESTDIR with prefix /usr (so /etc and /lib above are /etc and
# /lib), and its debug symbols split into ipsd-dbgsym (.ddeb). Version and Debian revision come
# from packaging/deb/changelog (installed as changelog.Debian.gz); its upstream part must be the
# project's version.
file(STRINGS ${PROJECT_SOURCE_DIR}/packaging/deb/changelog ips_changelog_head LIMIT_COUNT 1)
if(NOT ips_changelog_head MATCHES "^ipsd \\(([^-]+)-([^)]+)\\) ")
  message(FATAL_ERROR "packaging/deb/changelog: the first line is not 'ipsd (VERSION-REVISION) ...'")
endif()
if(NOT CMAKE_MATCH_1 STREQUAL PROJECT_VERSION)
  message(FATAL_ERROR "packaging/deb/changelog: its newest entry is ${CMAKE_MATCH_1}, the project is "
                      "${PROJECT_VERSION}: add an entry for ${PROJECT_VERSION}")
endif()
set(CPACK_DEBIAN_PACKAGE_RELEASE ${CMAKE_MATCH_2})
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/packaging/deb/changelog)
add_custom_command(OUTPUT ${PROJECT_BINARY_DIR}/packaging/changelog.Debian.gz
  COMMAND ${CMAKE_COMMAND} -E make_directory ${PROJECT_BINARY_DIR}/packaging
  COMMAND sh -c "gzip -9n < '${PROJECT_SOURCE_DIR}/packaging/deb/changelog' > '${PROJECT_BINARY_DIR}/packaging/changelog.Debian.gz'"
  DEPENDS ${PROJECT_SOURCE_DIR}/packaging/deb/changelog
  VERBATIM)
add_custom_target(ips_changelog ALL DEPENDS ${PROJECT_BINARY_DIR}/packaging/changelog.Debian.gz)
install(FILES ${PROJECT_BINARY_DIR}/packaging/changelog.Debian.gz DESTINATION ${CMAKE_INSTALL_DOCDIR})

# The Maintainer field; the address is the one the repository's commits carry.
set(IPS_PACKAGE_MAINTAINER "ipsd maintainers <maintainers@users.noreply.h-seed-e72e14fe.example>"
    CACHE STRING "Maintainer field of the Debian package")
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME ipsd)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "${IPS_PACKAGE_MAINTAINER}")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "indoor positioning daemon: ceiling cameras to ArUco marker positions")
set(CPACK_PACKAGE_DESCRIPTION "ipsd grabs frames from ceiling fisheye USB cameras, detects ArUco markers,\nmaps them to world coordinates with a per-camera model and streams positions\nover UDP. The ips toolbox calibrates cameras and fits the models; ipsd-demo\nruns the daemon on a simulated lab, no camera needed.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
# Shared libraries from dpkg-shlibdeps; python3 for /usr/share/ipsd/ipsd_client.py; the
# deb-systemd-helper/-invoke calls of the maintainer scripts (debhelper 13's snippets); adduser
# where systemd-sysusers is absent.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "adduser, init-system-helpers (>= 1.52), python3")
# Stripped programs; their symbols go to ipsd-dbgsym_<version>_<arch>.ddeb (/usr/lib/debug/.build-id).
set(CPACK_DEBIAN_DEBUGINFO_PACKAGE ON)
set(CPACK_POST_BUILD_SCRIPTS ${PROJECT_SOURCE_DIR}/packaging/deb/dbgsym_fixup.cmake)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/packaging/deb/conffiles
    ${PROJECT_SOURCE_DIR}/packaging/deb/postinst
    ${PROJECT_SOURCE_DIR}/packaging/deb/prerm
    ${PROJECT_SOURCE_DIR}/packaging/deb/postrm)
include(CPack)
