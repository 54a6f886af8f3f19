# Installation and the Debian package.
#   cmake --install build/release [--prefix /usr/local]   programs, unit, sysusers.d, example config, docs
#   bash tools/package.sh                                  build/package/ipsd_<version>_<arch>.deb
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
install(FILES ${PROJECT_BINARY_DIR}/packaging/ipsd.service DESTINATION "/\${IPS_UNIT_DIR}")
install(FILES packaging/sysusers.conf DESTINATION lib/sysusers.d RENAME ipsd.conf)
install(FILES config/ipsd.yaml DESTINATION "/\${IPS_ETC_DIR}")
install(FILES README.md DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES tools/ipsd_client.py DESTINATION ${CMAKE_INSTALL_DATADIR}/ipsd
        PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
# Example data a new lab can try ipsd with before it has calibrated anything: the simulated
# published lab (scenes, lenses) and the published calibration pairs and intrinsics.
install(DIRECTORY config/scenes DESTINATION ${CMAKE_INSTALL_DATADIR}/ipsd/examples)
install(FILES config/demo.yaml DESTINATION ${CMAKE_INSTALL_DATADIR}/ipsd/examples)
install(DIRECTORY calib_data/ou2023 DESTINATION ${CMAKE_INSTALL_DATADIR}/ipsd/examples/calib_data)

# ---------------------------------------------------------------------------
# CPack: one .deb, staged under DESTDIR with prefix /usr (so /etc and /lib above are /etc and
# /lib); dependencies come from dpkg-shlibdeps on the installed programs.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME ipsd)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "ipsd maintainers <ipsd@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "indoor positioning daemon: ceiling cameras -> ArUco marker positions over UDP")
set(CPACK_PACKAGE_DESCRIPTION "ipsd grabs frames from ceiling fisheye USB cameras, detects ArUco markers,\nmaps them to world coordinates with a per-camera model and streams positions.\nThe ips toolbox calibrates cameras and fits the models.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "adduser, init-system-helpers")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/packaging/deb/conffiles
    ${PROJECT_SOURCE_DIR}/packaging/deb/postinst
    ${PROJECT_SOURCE_DIR}/packaging/deb/prerm
    ${PROJECT_SOURCE_DIR}/packaging/deb/postrm)
include(CPack)
