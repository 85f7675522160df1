# Every fenced code block of shadows/README.md must appear verbatim in the consumer's sources,
# so the guide cannot drift from code that compiles and runs.
#   cmake -DGUIDE=shadows/README.md -DCONSUMER=tests/consumer -P check_guide_snippets.cmake
file(READ ${GUIDE} guide)
# CMake lists split on ';': stand it in for a marker so each block stays one list element.
string(REPLACE ";" "<semicolon>" guide "${guide}")
set(sources "")
foreach(f main.cpp shadows_integration.hpp scene.frag scene.vert
          CMakeLists.txt)
  file(READ ${CONSUMER}/${f} text)
  string(REPLACE ";" "<semicolon>" text "${text}")
  string(APPEND sources "${text}\n")
endforeach()
string(REGEX MATCHALL "```(cpp|glsl|cmake)\n[^`]*```" blocks "${guide}")
list(LENGTH blocks count)
set(checked 0)
foreach(block IN LISTS blocks)
  string(REGEX REPLACE "^```[a-z]+\n" "" body "${block}")
  string(REGEX REPLACE "```$" "" body "${body}")
  # Blocks that show how to use the package rather than consumer code are marked by what they
  # start with: find_package/add_subdirectory lines and shell commands are not checked.
  if(body MATCHES "^find_package|^cmake ")
    continue()
  endif()
  string(FIND "${sources}" "${body}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "guide snippet not found in tests/consumer:\n${body}")
  endif()
  math(EXPR checked "${checked} + 1")
endforeach()
if(checked LESS 8)
  message(FATAL_ERROR "only ${checked} snippets checked; expected at least 8")
endif()
message(STATUS "${checked} guide snippets found verbatim in tests/consumer")
