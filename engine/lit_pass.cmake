# The engine's lit pass (engine/include/engine/lit_pass.hpp) and its shaders. Included (once)
# by whatever needs it: the GPU tests and csm_gpu_bench. It lives beside the engine because it is
# engine code: it knows nothing of cascades, only a "shadow resources" descriptor set.
include_guard(GLOBAL)
csm_compile_shaders(csm_lit_shaders lit.vert lit.frag)
add_library(csm_lit_pass STATIC ${CMAKE_CURRENT_LIST_DIR}/src/lit_pass.cpp)
target_include_directories(csm_lit_pass PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src)
target_link_libraries(csm_lit_pass PUBLIC csm::engine PRIVATE csm_lit_shaders)
csm_target_warnings(csm_lit_pass)
