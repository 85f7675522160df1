// The cache's per-frame decisions, as plain arithmetic: whether a cascade keeps its world-
// anchored window (texel grid and depth range) or opens a new one, and which cascades a texel
// budget refreshes this frame. The renderer's cached pass (csm::vk, RendererOptions::cache)
// applies them; see shadows/docs/cache.md.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include "csm/cache_rects.hpp"
#include "csm/cascades.hpp"
#include "csm/receiver_tiles.hpp"

namespace csm {

/// A cascade's world-anchored window: the texel size and light direction it was opened with,
/// the world texel index drawn at layer texel (0, 0) (the layer is toroidal from there), and
/// its absolute light-space depth range.
struct CacheWindowPlacement {
  bool valid = false;
  double texel = 0.0;
  glm::dvec3 lightDirection{0.0};
  std::int64_t anchorX = 0, anchorY = 0;
  double zNear = 0.0, zFar = 0.0;
};

/// The world texel index of the first texel of a box of `res` texels a side centred at
/// light-space x, y `centerLs` on a grid of `texel` metres: round(center / texel) - res / 2.
[[nodiscard]] std::int64_t cacheBoxStart(double centerLs, double texel, std::int64_t res) noexcept;

/// Keeps `window` while it serves a cascade with texels of `texel` metres under the light
/// `lightDirection` whose depths [needNearLs, needFarLs] (absolute, light space) it must hold:
/// the same texel and light, the needed range inside its depth window, and that window at most
/// 2.5 times the range (else depth precision would be wasted). Otherwise opens a new window
/// anchored at (boxX, boxY), its depth window the needed range rounded out to multiples of a
/// quarter of it plus a quarter of margin each side (so that it stays while the box's depth
/// follows the camera). Returns whether it opened a new window (the layer is re-rendered).
bool placeCacheWindow(CacheWindowPlacement& window, double texel, const glm::dvec3& lightDirection,
                      std::int64_t boxX, std::int64_t boxY, double needNearLs, double needFarLs);

/// One cascade as the texel budget sees it.
struct CacheRefreshCandidate {
  bool active = false;            // non-empty this frame
  bool shown = false;             // its layer shows an earlier refresh
  std::uint32_t lagFrames = 0;    // frames since that refresh
  bool covered = true;            // what it shows still covers this frame's slice
  std::uint64_t staleTexels = 0;  // what refreshing it renders
};

/// The cascades refreshed this frame (bit i for cascade i); the other active ones keep showing
/// their last refresh. With no budget (0) every active cascade. Else the first `exactCascades`
/// and any never shown whatever they cost; then the others, most stale first (frames of lag,
/// one more for a cascade that no longer covers its slice, and among equals the uncovered
/// first, then the nearer), each while its stale texels fit what is left of the budget (a
/// cascade that does not fit is passed over, not waited for).
[[nodiscard]] std::uint32_t scheduleCacheRefresh(std::span<const CacheRefreshCandidate> cascades,
                                                 std::uint64_t budgetTexels,
                                                 std::uint32_t exactCascades);

/// A cascade's static layer: its window (placeCacheWindow) and what the layer holds of it.
struct CacheLayerState : CacheWindowPlacement {
  bool staticValid = false;              // the layer holds box (boxX, boxY) of the window
  std::int64_t boxX = 0, boxY = 0;       // world texel of the box's first texel
  std::vector<AabbWs> pending;           // invalidated world boxes not yet re-rendered
  std::uint64_t wholeInvalidations = 0;  // times the whole layer was invalidated
  /// Receiver-marked tiles (CacheTileInputs): the layer holds only the tiles set in `tiles`
  /// (each whole, as far as it lies in the box); elsewhere it holds nothing usable.
  bool partial = false;
  TileMask tiles;
};

/// What a cascade's sampled layer shows: its last refresh (the window, slice and light basis
/// it was drawn with). A cascade deferred by the budget keeps showing it.
struct CacheShownState {
  bool valid = false;
  std::uint32_t lagFrames = 0;  // frames since its last refresh
  CacheWindowPlacement window;  // anchor, texel, depth window
  Cascade cascade;
  glm::dmat3 basis{1.0};
  /// Receiver-marked tiles: the layer shows only these tiles (CacheLayerState::tiles).
  bool partial = false;
  TileMask tiles;
};

/// The cache's state between frames, per cascade: the static layer and what the sampled layer
/// shows. planCacheFrame() reads and advances it; the renderer records what the plan says and
/// marks the static layers it re-rendered (markCacheRecorded).
struct CacheState {
  std::array<CacheLayerState, kMaxCascades> layers{};
  std::array<CacheShownState, kMaxCascades> shown{};
  /// Receiver-marked tiles: frames planned in a row without marks (after a cut, until the
  /// first depth buffer after it has been reduced). The first of them falls back; the others
  /// draw what the view can sample (csm::markFrustumTiles).
  std::uint32_t unmarkedFrames = 0;
};

/// One cascade's part of a frame's cache plan.
struct CacheCascadePlan {
  bool active = false;     // non-empty this frame
  bool newWindow = false;  // its static layer holds nothing (a new window, or invalidated whole)
  bool covered = false;    // what the layer showed before covers this frame's slice
  bool refreshed = false;  // drawn this frame; else deferred: it shows its last refresh
  std::uint32_t lagFrames = 0;  // frames since the refresh it shows (0 when refreshed)
  /// The light basis of what the layer shows (the frame's unless deferred across a change of
  /// light): the cascade is drawn, culled and addressed in it.
  glm::dmat3 basis{1.0};
  /// The world texels of the box the layer shows, in the window it shows, and where the box's
  /// first texel sits in the toroidal layer: (box.x0 - anchorX) mod res, likewise y.
  TexelRect box;
  std::int64_t wrapX = 0, wrapY = 0;
  /// What refreshing the static layer renders: its stale rectangles (staleRects: newly exposed
  /// rows and columns, invalidated boxes), `full` when that is the whole box. Empty for a
  /// deferred cascade, which draws none of it.
  std::vector<TexelRect> stale;
  bool full = false;
  std::uint64_t staleTexels = 0;  // what its refresh would cost, deferred or not
  /// The static layer's pending boxes and whole invalidations the stale rectangles account
  /// for (invalidations after planning: updateCacheStale).
  std::size_t pendingPlanned = 0;
  std::uint64_t wholeInvalidations = 0;
  /// Receiver-marked tiles (planCacheFrame with CacheTileInputs). `partial`: the cascade draws
  /// only what the marks ask for and its layer shows only `tiles` (after this frame's draw; for
  /// a deferred cascade, what it shows); a pixel whose footprint is not in them falls back to a
  /// coarser cascade (csm.glsl). `marked`: the marks carried onto the cascade's grid. Counts:
  /// tiles marked, and tiles of which something is drawn this frame.
  bool partial = false;
  TileMask tiles;
  TileMask marked;
  std::uint32_t tilesMarked = 0;
  std::uint32_t tilesDrawn = 0;
  /// CacheTileInputs::budgetTexels: marked tiles in the box that the budget left for a later
  /// frame (not held after this frame: their pixels fall back).
  std::uint32_t tilesDeferred = 0;
  /// The camera's light-space x, y in the cascade's texels (the tile budget draws the tiles
  /// nearest to it first).
  glm::dvec2 cameraTexel{0.0};
};

/// Receiver-marked tiles: a partial cascade also draws whole the gaps of up to this many tiles
/// between two tiles of a row it draws whole (marked, not held), and holds them: one scissor,
/// and one draw per caster, instead of several (a CPU rasteriser pays per draw).
inline constexpr std::int64_t kTileGapFill = 2;
/// Receiver-marked tiles: a partial cascade whose draw has more pieces than this draws instead
/// the rectangle around them where that is at most twice their area (and holds every tile
/// inside it).
inline constexpr std::size_t kTilePiecesBeforeBounds = 8;

/// Receiver-marked tiles for planCacheFrame (RendererOptions::tiles): which tiles the visible
/// pixels sample, and how far each cascade's filter reads.
struct CacheTileInputs {
  /// The latest marks (csm::ReceiverTileMarks from the host's depth buffer, a few frames old);
  /// null or absent (cascadeCount 0): none yet (after a cut). The first frame without marks
  /// draws nothing more in the partial cascades (their pixels fall back); the next ones draw
  /// what the frame's view can sample (csm::markFrustumTiles) until marks arrive. Marks are
  /// used only where the frame's view can sample them, and the last cascade is drawn where the
  /// view can sample it (a frame without its camera's frustum: whole).
  const ReceiverTileMarks* marks = nullptr;
  /// Per cascade, how far (texels) its filter reads around a receiver
  /// (csm::receiverSampleReachTexels for the frame's settings).
  std::array<double, kMaxCascades> reachTexels{};
  /// The most static texels the partial cascades other than the last draw in one frame, 0 = no
  /// cap. Their stale texels in held tiles go first, then the marked tiles they do not hold,
  /// from the camera out; the cascades from the first out, and once one cascade's next piece
  /// does not fit, no later cascade draws either. What is left waits for later frames (not held:
  /// its pixels fall back to a coarser cascade). The last cascade (the fallback) and cascades
  /// drawn whole are not counted.
  std::uint64_t budgetTexels = 0;
};

/// One frame's cache decisions for every cascade, from planCacheFrame().
struct CachePlan {
  std::uint32_t cascadeCount = 0;
  std::uint32_t resolution = 0;
  std::uint32_t refreshedMask = 0;  // bit i: cascade i refreshed
  std::array<CacheCascadePlan, kMaxCascades> cascades{};
  /// CacheTileInputs::budgetTexels the plan was made with (0 = no cap).
  std::uint64_t tileBudgetTexels = 0;
};

/// Whether what a layer shows (`shown`) covers slice `c` of a frame in light basis `basis`
/// (before its depth window is applied): its box holds the box the slice needs (the slice's
/// sphere, across a change of light) and its depth window the sphere.
[[nodiscard]] bool cacheShownCovers(const CacheShownState& shown, const Cascade& c,
                                    const glm::dmat3& basis) noexcept;

/// The cache's decisions for `frame` (stabilised, at `resolution`), applied to the frame and
/// the state: each active cascade keeps its window or opens one (placeCacheWindow); its depth
/// range becomes the window's and its matrix is formed again (cameraRelativeViewProj); its stale
/// texels are counted; the budget picks the cascades refreshed (scheduleCacheRefresh with
/// `budgetTexels`, 0: all, and `exactCascades`); a refreshed cascade's shown state becomes this
/// frame's, a deferred one's cascade becomes what it shows (its matrix formed for this frame's
/// camera). A frame of another resolution, or none, is left as it is: the plan is then empty.
///
/// With `tiles` (receiver-marked tiles), the last active cascade is the fallback: refreshed
/// every frame and drawn over every tile the frame's view can sample in it
/// (csm::markFrustumTiles over its own depths and, when another cascade is partial, every depth
/// of the shadows: whole for a frame without its camera's frustum), so no pixel that reads it
/// misses. Every other active cascade whose slice (its bounding sphere, widened by the last
/// cascade's filter reach and two texels) lies inside the last cascade's box and depth window is
/// partial (cacheBoxHoldsSphere): it draws only the stale texels of marked tiles (the marks
/// carried onto its grid, carryTileMarks, across a light step through its sphere's depth range,
/// and only where the view can sample them) and every marked tile it does not hold yet, whole
/// (with gaps of up to kTileGapFill tiles between two such in a row); a stale texel in a tile it
/// does not draw makes that tile not held, until a mark asks for it. Without marks, the first
/// frame marks nothing and the next ones what the view can sample (CacheState::unmarkedFrames),
/// except on the view's first frame (no layer shown yet), which draws every cascade whole.
/// A cascade that stops being partial draws what it did not hold.
CachePlan planCacheFrame(CascadeFrame& frame, CacheState& state, std::uint32_t resolution,
                         std::uint64_t budgetTexels, std::uint32_t exactCascades,
                         const CacheTileInputs* tiles = nullptr);

/// Whether the box `outerBox` (world texels of `outerTexelM` metres in light basis `basis`) less
/// `marginM` each side, and the absolute light-space depth window [zNearLs, zFarLs], hold the
/// sphere of cascade `inner`: every receiver that cascade shades then lies in the box, so its
/// pixels can fall back to it.
[[nodiscard]] bool cacheBoxHoldsSphere(const TexelRect& outerBox, double outerTexelM,
                                       const glm::dmat3& basis, double zNearLs, double zFarLs,
                                       double marginM, const Cascade& inner) noexcept;

/// Brings the stale rectangles of `plan`'s refreshed cascades up to date with what was
/// invalidated after planning (invalidateCache between planCacheFrame and recording), so the
/// frame recorded holds them. Cascades invalidated since keep their place in the budget.
void updateCacheStale(CachePlan& plan, const CacheState& state);

/// After the cascades of `plan` were recorded: each refreshed cascade's static layer holds its
/// box, and the pending boxes its stale rectangles accounted for are done. A layer invalidated
/// whole since planning stays invalid.
void markCacheRecorded(const CachePlan& plan, CacheState& state);

/// Invalidates `boxWs` in every static layer that holds something: added to its pending boxes
/// (re-rendered at its next refresh), or with 64 pending already, the whole layer.
void invalidateCache(CacheState& state, const AabbWs& boxWs);

/// Invalidates every static layer whole.
void invalidateCacheAll(CacheState& state) noexcept;

}  // namespace csm
