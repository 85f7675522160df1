// The whole pure cascade math (no Vulkan): include this, link csm::core.
#pragma once

#include "csm/cache_plan.hpp"
#include "csm/cascades.hpp"
#include "csm/culling.hpp"
#include "csm/error.hpp"
#include "csm/frustum.hpp"
#include "csm/ladder.hpp"
#include "csm/light_space.hpp"
#include "csm/receiver_bounds.hpp"
#include "csm/selection.hpp"
#include "csm/splits.hpp"
#include "csm/thin_casters.hpp"
#include "csm/types.hpp"
#include "csm/version.hpp"
