# The module graph from the CMake targets themselves: every library of ours (teamscan_*), its folder
# (the module) and the modules it links. teamscan_module_graph() checks it, and the headers each module
# includes, against the layering of DESIGN.md "Layout" (dependencies point down the table, never back
# up, so no two modules include each other; a violation stops the configure) and writes ${CMAKE_BINARY_DIR}/module_graph.md, the table docs/architecture.md carries
# (checked by the test architecture_doc_test).

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
  "groundstation/fusion:common common/dataset idl dds groundstation/mapping groundstation/registration"
  "groundstation/view:common dds/ros2"
  "groundstation/station:common common/dataset idl dds dds/security dds/ros2 groundstation/mapping groundstation/fusion groundstation/registration groundstation/trajectory groundstation/view"
  "tools/render:common common/dataset"
  "tools/pki:common dds/security"
  "tools/mcap_export:common common/dataset common/mcap idl dds/ros2 onboard/core groundstation/fusion groundstation/station"
  "tools/demo:common common/dataset sim groundstation/mapping groundstation/fusion groundstation/registration groundstation/station tools/render tools/pki"
)

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
  set(table "| module | targets | links (modules of ours) |\n| --- | --- | --- |\n")
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
    string(APPEND table "| `${m}/` | ${ts} | ${ds} |\n")
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
    message(FATAL_ERROR "Module layering violated (DESIGN.md \"Layout\"):\n${violations}")
  endif()
  file(WRITE ${CMAKE_BINARY_DIR}/module_graph.md "${table}")
endfunction()
