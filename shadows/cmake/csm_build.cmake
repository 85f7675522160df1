# Build helpers of the module, usable by a host that vendors shadows/ alone:
#   csm_target_warnings(<target>)   warnings are errors in our own targets (never a consumer's)
#   csm_compile_shaders(<target> [SOURCE_DIR <dir>] <shader>...)   GLSL -> SPIR-V at build time
# and the variables a host's own GLSL build needs:
#   CSM_SHADER_INCLUDE_DIRS   -I each of them to #include "csm.glsl" (it includes csm/*.h)
#   CSM_SHADER_OUT            where csm_compile_shaders writes csm_shaders/<file>.spv(.h)
include_guard(GLOBAL)

if(NOT COMMAND csm_target_warnings)
  function(csm_target_warnings target)
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Werror)
  endfunction()
endif()

find_program(GLSLANG_VALIDATOR glslangValidator REQUIRED)

get_filename_component(_csm_module_dir ${CMAKE_CURRENT_LIST_DIR} DIRECTORY)
# csm.glsl and the depth shaders.
set(CSM_MODULE_SHADER_DIR ${_csm_module_dir}/shaders CACHE INTERNAL "")
# The C/GLSL headers with what both sides share (csm/shared_constants.h, csm/gpu_shared.h).
set(CSM_SHARED_INCLUDE_DIR ${_csm_module_dir}/include CACHE INTERNAL "")
set(CSM_SHADER_INCLUDE_DIRS ${CSM_MODULE_SHADER_DIR} ${CSM_SHARED_INCLUDE_DIR} CACHE INTERNAL "")
set(CSM_SHADER_OUT ${CMAKE_CURRENT_BINARY_DIR}/generated CACHE INTERNAL "")
file(MAKE_DIRECTORY ${CSM_SHADER_OUT}/csm_shaders)

# csm_compile_shaders(<target> [SOURCE_DIR <dir>] <shader files>...)
# Compiles each shader with glslang (Vulkan 1.3; a shader error fails the build with the file and
# line glslangValidator prints) into `<file>.spv` and `<file>.spv.h`, a C array named
# `<stem>_<stage>_spv`, and creates INTERFACE library <target> whose include path holds them
# (#include <csm_shaders/<file>.spv.h>), so no binary depends on where the build tree lives.
# Relative names resolve against SOURCE_DIR, else ${CSM_SHADERS_DIR} when the host set it, else
# the calling directory. csm.glsl and its headers are always on the include path.
function(csm_compile_shaders target)
  cmake_parse_arguments(arg "" "SOURCE_DIR" "" ${ARGN})
  if(arg_SOURCE_DIR)
    set(dir ${arg_SOURCE_DIR})
  elseif(CSM_SHADERS_DIR)
    set(dir ${CSM_SHADERS_DIR})
  else()
    set(dir ${CMAKE_CURRENT_SOURCE_DIR})
  endif()
  set(includes -I${dir})
  foreach(inc IN LISTS CSM_SHADER_INCLUDE_DIRS)
    list(APPEND includes -I${inc})
  endforeach()
  set(outputs)
  foreach(src IN LISTS arg_UNPARSED_ARGUMENTS)
    get_filename_component(name ${src} NAME)
    get_filename_component(stem ${src} NAME_WE)
    get_filename_component(ext ${src} LAST_EXT)
    string(SUBSTRING ${ext} 1 -1 stage)
    set(spv ${CSM_SHADER_OUT}/csm_shaders/${name}.spv)
    set(hdr ${CSM_SHADER_OUT}/csm_shaders/${name}.spv.h)
    get_filename_component(abs ${src} ABSOLUTE BASE_DIR ${dir})
    add_custom_command(
      OUTPUT ${spv} ${hdr}
      COMMAND ${GLSLANG_VALIDATOR} --quiet --target-env vulkan1.3 ${includes}
              --depfile ${spv}.d -o ${spv} ${abs}
      COMMAND ${GLSLANG_VALIDATOR} --quiet --target-env vulkan1.3 ${includes}
              --vn ${stem}_${stage}_spv -o ${hdr} ${abs}
      DEPENDS ${abs}
      DEPFILE ${spv}.d
      COMMENT "glslang ${src}"
      VERBATIM)
    list(APPEND outputs ${spv} ${hdr})
  endforeach()
  add_custom_target(${target}_compile DEPENDS ${outputs})
  add_library(${target} INTERFACE)
  add_dependencies(${target} ${target}_compile)
  target_include_directories(${target} INTERFACE $<BUILD_INTERFACE:${CSM_SHADER_OUT}>)
endfunction()
