# Install rules shared by every folder. Each folder installs what it builds, next to the target:
#   teamscan_install_program(TARGET COMPONENT c SUMMARY "...")   binary + man page (help2man) + component
#   install(FILES ... DESTINATION ${TEAMSCAN_INSTALL_DATADIR}/<sub> COMPONENT c)   data files
# A program finds installed data files with common/data_paths.hpp find_data_file("<sub>/<file>", "<source path>").
# Components are the Debian packages (cmake/TeamscanPackaging.cmake):
#   common -> teamscan-common   (DDS configs, the teamscan user, README and docs; every other package needs it)
#   onboard -> teamscan-onboard, groundstation -> teamscan-groundstation, tools -> teamscan-tools
# Everything a package needs built (programs, man pages, bundled web pages, ...) is a dependency of the
# target teamscan_install_set, which the package build makes instead of `all` (no tests, no benchmarks).
include(GNUInstallDirs)
set(TEAMSCAN_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/teamscan)
set(TEAMSCAN_INSTALL_EXAMPLESDIR ${TEAMSCAN_INSTALL_DATADIR}/examples)
set(TEAMSCAN_INSTALL_UNITDIR lib/systemd/system)  # /usr/lib/systemd/system, /usr/local/lib/systemd/system
set(TEAMSCAN_INSTALL_SYSUSERSDIR lib/sysusers.d)
find_program(TEAMSCAN_HELP2MAN help2man REQUIRED)
find_program(TEAMSCAN_GZIP gzip REQUIRED)

add_custom_target(teamscan_install_set)

# teamscan_install_program(TARGET COMPONENT c SUMMARY "one line for the man page's NAME section")
# Installs the program to bin/ and its man page, made at build time from its --help and --version
# (so the page never disagrees with the program), to share/man/man1.
function(teamscan_install_program target)
  cmake_parse_arguments(ARG "" "COMPONENT;SUMMARY" "" ${ARGN})
  install(TARGETS ${target} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT ${ARG_COMPONENT})
  set(man ${CMAKE_BINARY_DIR}/man/${target}.1)
  add_custom_command(OUTPUT ${man}.gz
    COMMAND ${CMAKE_COMMAND} -E make_directory ${CMAKE_BINARY_DIR}/man
    COMMAND ${TEAMSCAN_HELP2MAN} --no-info --no-discard-stderr --section=1 --name=${ARG_SUMMARY}
            --output=${man} $<TARGET_FILE:${target}>
    COMMAND ${TEAMSCAN_GZIP} -9nf ${man}
    DEPENDS ${target}
    COMMENT "Man page ${target}.1 (help2man)"
    VERBATIM)
  add_custom_target(${target}_man ALL DEPENDS ${man}.gz)
  add_dependencies(teamscan_install_set ${target}_man)
  install(FILES ${man}.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT ${ARG_COMPONENT})
endfunction()
