# The module graph from the CMake targets themselves: every library of ours (teamscan_*), its folder
# (the module) and the modules it links. teamscan_module_graph() checks it, and the headers each module
# includes, against the layering of DESIGN.md "Layout" (dependencies point down the table, never back
# up, so no two modules include each other; a violation stops the configure) and writes ${CMAKE_BINARY_DIR}/module_graph.md, the table docs/architecture.md carries
# (checked by the test architecture_doc_test). It also checks that each module's sources open only its
# own namespace (TEAMSCAN_MODULE_NAMESPACES) or one nested in it, and writes that namespace into the table.

# Which modules each module may link (DESIGN.md "Layout"); a module may always link its own folder.
set(TEAMSCAN_ALLOWED_DEPS
  "idl:"
  "common:"
  "common/dataset:common"
  "common/mcap:common"
  "drivers/serial:common"
  "drivers/arcos:common drivers/serial"
  "drivers/lms200:common drivers/serial"
  "dds/security:common"
  "dds:common idl dds/security"
  "dds/ros2:common idl dds"
  "onboard/cone:common"
  "onboard/core:common onboard/cone"
  "onboard/ring:common drivers/serial onboard/core"
  "onboard/bridge:common dds idl onboard/core"
  "onboard/daemon:common drivers/serial drivers/arcos drivers/lms200 dds dds/security onboard/cone onboard/core onboard/ring onboard/bridge"
  "sim:common common/dataset drivers/serial drivers/arcos drivers/lms200"
  "groundstation/registration:common"
  "groundstation/trajectory:common common/dataset"
  "groundstation/posegraph:common common/dataset"
  "groundstation/mapping:common common/dataset onboard/cone groundstation/registration"
  "groundstation/fusion:common common/dataset idl dds groundstation/mapping groundstation/registration groundstation/posegraph"
  "groundstation/view:common dds/ros2"
  "groundstation/station:common common/dataset idl dds dds/security dds/ros2 groundstation/mapping groundstation/fusion groundstation/registration groundstation/trajectory groundstation/view"
  "tools/render:common common/dataset"
  "tools/pki:common dds/security"
  "tools/mcap_export:common common/dataset common/mcap idl dds/ros2 onboard/core groundstation/fusion groundstation/station"
  "tools/demo:common common/dataset sim groundstation/mapping groundstation/fusion groundstation/registration groundstation/station groundstation/trajectory tools/render tools/pki"
)

# Each module's namespace: a folder's own name under teamscan (the folders groundstation/, drivers/ and
# tools/ group modules and add no level). common/ and common/dataset/ hold the vocabulary every module
# speaks (time, units, poses, the scan, the data set) and stay in teamscan itself; onboard/core/, bridge/
# and daemon/ are the robot program's three layers (no I/O, DDS, the loop) in its one namespace, which
# its ring nests in; the direction cone both sides decide with is a namespace of its own.
set(TEAMSCAN_MODULE_NAMESPACES
  "common:teamscan"
  "common/dataset:teamscan"
  "common/mcap:teamscan::mcap"
  "drivers/serial:teamscan::serial"
  "drivers/arcos:teamscan::arcos"
  "drivers/lms200:teamscan::lms200"
  "dds/security:teamscan::dds::security"
  "dds:teamscan::dds"
  "dds/ros2:teamscan::dds::ros2"
  "onboard/cone:teamscan::cone"
  "onboard/core:teamscan::onboard"
  "onboard/ring:teamscan::onboard::ring"
  "onboard/bridge:teamscan::onboard"
  "onboard/daemon:teamscan::onboard"
  "sim:teamscan::sim"
  "groundstation/registration:teamscan::registration"
  "groundstation/trajectory:teamscan::trajectory"
  "groundstation/posegraph:teamscan::posegraph"
  "groundstation/mapping:teamscan::mapping"
  "groundstation/fusion:teamscan::fusion"
  "groundstation/view:teamscan::view"
  "groundstation/station:teamscan::station"
  "tools/render:teamscan::render"
  "tools/pki:teamscan::pki"
  "tools/mcap_export:teamscan::mcap_export"
  "tools/demo:teamscan::demo"
)

# The namespaces a module's own sources open (named ones under teamscan) that are neither its namespace
# nor nested in it, appended to the variable named by out_violations.
function(_teamscan_check_namespace m ns out_violations)
  set(v "${${out_violations}}")
  file(GLOB files ${TEAMSCAN_SOURCE_DIR}/${m}/*.hpp ${TEAMSCAN_SOURCE_DIR}/${m}/*.cpp)
  foreach(f ${files})
    file(STRINGS ${f} opens REGEX "^namespace teamscan[A-Za-z0-9_:]* {")
    foreach(line ${opens})
      string(REGEX REPLACE "^namespace (teamscan[A-Za-z0-9_:]*) {.*" "\\1" opened "${line}")
      string(FIND "${opened}::" "${ns}::" at)
      if(NOT opened STREQUAL ns AND NOT at EQUAL 0)
        file(RELATIVE_PATH rf ${TEAMSCAN_SOURCE_DIR} ${f})
        string(APPEND v "  ${rf} opens ${opened}, not ${m}/'s ${ns}\n")
      endif()
    endforeach()
  endforeach()
  set(${out_violations} "${v}" PARENT_SCOPE)
endfunction()

function(_teamscan_module_of target out)
  get_target_property(dir ${target} SOURCE_DIR)
  file(RELATIVE_PATH rel ${TEAMSCAN_SOURCE_DIR} ${dir})
  set(${out} ${rel} PARENT_SCOPE)
endfunction()

function(teamscan_module_graph)
  get_property(targets GLOBAL PROPERTY TEAMSCAN_LIBRARIES)
  list(SORT targets)
  set(modules "")
  foreach(t ${targets})
    _teamscan_module_of(${t} m)
    list(APPEND modules ${m})
    list(APPEND "_targets_${m}" ${t})
    get_target_property(links ${t} LINK_LIBRARIES)
    if(NOT links)
      set(links "")
    endif()
    foreach(l ${links})
      if(TARGET ${l} AND l IN_LIST targets)
        _teamscan_module_of(${l} lm)
        if(NOT lm STREQUAL m)
          list(APPEND "_deps_${m}" ${lm})
        endif()
      endif()
    endforeach()
  endforeach()
  list(REMOVE_DUPLICATES modules)
  list(SORT modules)
  set(table "| module | namespace | targets | links (modules of ours) |\n| --- | --- | --- | --- |\n")
  set(violations "")
  foreach(m ${modules})
    set(deps ${_deps_${m}})
    if(deps)
      list(REMOVE_DUPLICATES deps)
      list(SORT deps)
    endif()
    set(allowed "")
    set(known FALSE)
    foreach(rule ${TEAMSCAN_ALLOWED_DEPS})
      string(REPLACE ":" ";" parts "${rule}")
      list(GET parts 0 rm)
      if(rm STREQUAL m)
        set(known TRUE)
        list(LENGTH parts n)
        if(n GREATER 1)
          list(GET parts 1 a)
          string(REPLACE " " ";" allowed "${a}")
        endif()
      endif()
    endforeach()
    if(NOT known)
      string(APPEND violations "  ${m}: not in the layering (cmake/ModuleGraph.cmake TEAMSCAN_ALLOWED_DEPS)\n")
    endif()
    foreach(d ${deps})
      if(NOT "*" IN_LIST allowed AND NOT d IN_LIST allowed)
        string(APPEND violations "  ${m} -> ${d}\n")
      endif()
    endforeach()
    set(ts ${_targets_${m}})
    string(REPLACE ";" ", " ts "${ts}")
    string(REPLACE ";" ", " ds "${deps}")
    if(ds STREQUAL "")
      set(ds "–")
    endif()
    set(ns "")
    foreach(rule ${TEAMSCAN_MODULE_NAMESPACES})
      string(REPLACE ":" ";" parts "${rule}")
      list(GET parts 0 rm)
      if(rm STREQUAL m)
        list(SUBLIST parts 1 -1 nsparts)
        string(REPLACE ";" ":" ns "${nsparts}")
      endif()
    endforeach()
    if(ns STREQUAL "")
      if(NOT m STREQUAL "idl")
        string(APPEND violations "  ${m}: no namespace (cmake/ModuleGraph.cmake TEAMSCAN_MODULE_NAMESPACES)\n")
      endif()
      set(nsc "–")
    else()
      _teamscan_check_namespace(${m} ${ns} violations)
      set(nsc "`${ns}`")
    endif()
    string(APPEND table "| `${m}/` | ${nsc} | ${ts} | ${ds} |\n")
  endforeach()
  # The same rule for the headers a module includes: a header-only dependency (a template, a struct)
  # links nothing, so the link graph alone would not see it, nor a cycle of includes between modules.
  foreach(m ${modules})
    set(allowed "")
    foreach(rule ${TEAMSCAN_ALLOWED_DEPS})
      string(REPLACE ":" ";" parts "${rule}")
      list(GET parts 0 rm)
      list(LENGTH parts n)
      if(rm STREQUAL m AND n GREATER 1)
        list(GET parts 1 a)
        string(REPLACE " " ";" allowed "${a}")
      endif()
    endforeach()
    file(GLOB files ${TEAMSCAN_SOURCE_DIR}/${m}/*.hpp ${TEAMSCAN_SOURCE_DIR}/${m}/*.cpp)
    foreach(f ${files})
      file(STRINGS ${f} includes REGEX "^#include \"[a-z0-9_/]+/[^/\"]+\"")
      foreach(line ${includes})
        string(REGEX REPLACE "^#include \"([a-z0-9_/]+)/[^/\"]+\".*" "\\1" im "${line}")
        if(im IN_LIST modules AND NOT im STREQUAL m AND NOT im IN_LIST allowed)
          file(RELATIVE_PATH rf ${TEAMSCAN_SOURCE_DIR} ${f})
          string(APPEND violations "  ${m} -> ${im} (${rf} includes it)\n")
        endif()
      endforeach()
    endforeach()
  endforeach()
  if(violations)
    message(FATAL_ERROR "Module layering or namespaces violated (DESIGN.md \"Layout\"):\n${violations}")
  endif()
  file(WRITE ${CMAKE_BINARY_DIR}/module_graph.md "${table}")
endfunction()
