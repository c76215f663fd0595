# cmake -DGRAPH=<build>/module_graph.md -DDOC=<source>/docs/architecture.md -P CheckArchitectureDoc.cmake
# Fails when the table between the "module graph" markers of docs/architecture.md is not the one
# cmake/ModuleGraph.cmake generated from the targets (copy module_graph.md into the doc).
file(READ ${GRAPH} graph)
file(READ ${DOC} doc)
string(FIND "${doc}" "<!-- module graph: begin -->\n" b)
string(FIND "${doc}" "<!-- module graph: end -->" e)
if(b LESS 0 OR e LESS b)
  message(FATAL_ERROR "${DOC}: no <!-- module graph: begin/end --> markers")
endif()
string(LENGTH "<!-- module graph: begin -->\n" bl)
math(EXPR start "${b} + ${bl}")
math(EXPR len "${e} - ${start}")
string(SUBSTRING "${doc}" ${start} ${len} table)
if(NOT table STREQUAL graph)
  message(FATAL_ERROR "docs/architecture.md's module table differs from the targets' graph; the generated one is ${GRAPH}:\n${graph}")
endif()
message(STATUS "docs/architecture.md's module table is the targets' graph")
