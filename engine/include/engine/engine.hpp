// Everything of the engine in one include.
#pragma once

#include "engine/camera.hpp"
#include "engine/context.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "engine/gpu_timer.hpp"
#include "engine/headless_target.hpp"
#include "engine/image_io.hpp"
#include "engine/memory.hpp"
#include "engine/mesh_store.hpp"
#include "engine/pipeline.hpp"
#include "engine/render_target.hpp"
#include "engine/window_target.hpp"
