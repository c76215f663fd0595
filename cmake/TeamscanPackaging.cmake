# The Debian packages, one per install component (cmake/TeamscanInstall.cmake):
#   teamscan-common         (all)  DDS configs, the teamscan user (sysusers.d), README and docs
#   teamscan-onboard               the robot daemon, its unit, example robot configs, the serial group
#   teamscan-groundstation         the ground station, its unit, its example config
#   teamscan-tools                 the teamscan tool and the scenarios
# Build: cmake --preset package && cmake --build --preset package && cpack --preset package
# (scripts/check-install.sh does it and checks the installed result). Runtime dependencies come from
# dpkg-shlibdeps; the maintainer scripts (deploy/debian) create the user and enable nothing.
set(TEAMSCAN_PACKAGE_MAINTAINER "teamscan maintainers <maintainers@users.noreply.h-seed-03d5ff0f.example>"
    CACHE STRING "Maintainer field of the Debian packages")
set(TEAMSCAN_PACKAGE_COMPONENTS common onboard groundstation tools)

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME teamscan)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "${TEAMSCAN_PACKAGE_MAINTAINER}")
set(CPACK_PACKAGE_VENDOR "teamscan")
set(CPACK_PACKAGING_INSTALL_PREFIX ${CMAKE_INSTALL_PREFIX})
set(CPACK_STRIP_FILES ON)
set(CPACK_COMPONENTS_ALL ${TEAMSCAN_PACKAGE_COMPONENTS})
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_RELEASE 1)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_ENABLE_COMPONENT_DEPENDS ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "multi-robot laser fusion with ghost-point removal")
set(deb_version "${PROJECT_VERSION}-${CPACK_DEBIAN_PACKAGE_RELEASE}")

# Descriptions: the first line is the synopsis; Debian wants the others under 80 columns.
set(CPACK_COMPONENT_COMMON_DESCRIPTION "teamscan robot-team 3-D mapping: shared files
A team of Pioneer 3-AT robots with tilted SICK LMS-200 lasers surveys a
confined area; a ground station fuses their scans into one 3-D model and
removes the ghost points where one robot's laser hit a teammate. This
package holds what the others share: the Cyclone DDS configs (loopback
and site template), the teamscan system user and the documentation.")
set(CPACK_DEBIAN_COMMON_PACKAGE_ARCHITECTURE all)
set(CPACK_DEBIAN_COMMON_PACKAGE_DEPENDS "systemd | systemd-standalone-sysusers")

set(CPACK_COMPONENT_ONBOARD_DESCRIPTION "teamscan robot daemon (Pioneer 3-AT + SICK LMS-200)
teamscan-onboard runs on every robot: it drives the Pioneer 3-AT (ARCOS)
and the SICK LMS-200 over serial, turns every scan into 3-D points in the
map frame, flags teammates with the direction filter and publishes pose,
scans and status over Cyclone DDS. The systemd unit
teamscan-onboard@.service (Type=notify, watchdog, hardened) is installed
but not enabled; example configs are in /usr/share/teamscan/examples.")
set(CPACK_COMPONENT_ONBOARD_DEPENDS common)

set(CPACK_COMPONENT_GROUNDSTATION_DESCRIPTION "teamscan ground station (DDS receiver, tracker, fusion)
teamscan-groundstation receives every robot's poses and scans over
Cyclone DDS, stores them in a session folder, tracks the robots with a
Kalman filter, publishes the team's state back and fuses the live 3-D
model. The systemd unit teamscan-groundstation.service is installed but
not enabled; an example config is in /usr/share/teamscan/examples.")
set(CPACK_COMPONENT_GROUNDSTATION_DEPENDS common)

set(CPACK_COMPONENT_TOOLS_DESCRIPTION "teamscan tool (simulate, emulate, evaluate, render, demo)
The teamscan command: simulates team surveys from the shipped scenarios,
emulates the robots' devices on pseudo-terminals, records and replays
serial captures, decodes the protocols, evaluates the ghost-point
filters, renders data sets and runs the whole system end to end
(teamscan demo).")
set(CPACK_COMPONENT_TOOLS_DEPENDS common)
set(CPACK_DEBIAN_TOOLS_PACKAGE_RECOMMENDS "teamscan-onboard (= ${deb_version}), teamscan-groundstation (= ${deb_version})")

# Per package: its name, its maintainer scripts (deploy/debian), /usr/share/doc/<package>/copyright
# and changelog.Debian.gz (Debian policy 12.5 and 12.7).
string(TIMESTAMP changelog_date "%a, %d %b %Y %H:%M:%S +0000" UTC)
set(changelog "teamscan (${deb_version}) unstable; urgency=medium\n\n  * Built by cpack from the teamscan sources.\n\n -- ${TEAMSCAN_PACKAGE_MAINTAINER}  ${changelog_date}\n")
file(WRITE ${CMAKE_BINARY_DIR}/debian/changelog.Debian "${changelog}")
execute_process(COMMAND gzip -9nf ${CMAKE_BINARY_DIR}/debian/changelog.Debian COMMAND_ERROR_IS_FATAL ANY)
set(scripts_onboard postinst:onboard.postinst prerm:onboard.prerm postrm:service.postrm)
set(scripts_groundstation postinst:groundstation.postinst prerm:groundstation.prerm postrm:service.postrm)
set(scripts_common postinst:common.postinst)
set(scripts_tools "")
foreach(component ${TEAMSCAN_PACKAGE_COMPONENTS})
  string(TOUPPER ${component} C)
  set(package teamscan-${component})
  set(CPACK_DEBIAN_${C}_PACKAGE_NAME ${package})
  set(CPACK_DEBIAN_${C}_FILE_NAME DEB-DEFAULT)
  set(extra "")
  foreach(pair ${scripts_${component}})
    string(REPLACE ":" ";" pair "${pair}")
    list(GET pair 0 script)
    list(GET pair 1 source)
    configure_file(${TEAMSCAN_SOURCE_DIR}/deploy/debian/${source} ${CMAKE_BINARY_DIR}/debian/${component}/${script} COPYONLY)
    list(APPEND extra ${CMAKE_BINARY_DIR}/debian/${component}/${script})
  endforeach()
  set(CPACK_DEBIAN_${C}_PACKAGE_CONTROL_EXTRA "${extra}")
  install(FILES ${TEAMSCAN_SOURCE_DIR}/deploy/debian/copyright ${CMAKE_BINARY_DIR}/debian/changelog.Debian.gz
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/${package} COMPONENT ${component})
endforeach()

include(CPack)
