// What is found once per scene and shared by every frame of it: the scene itself, its
// view-independent facts (core/facts/scene_facts.h) and its Loop plans (the subdivision surfaces'
// topology and stencils). The CLI keeps one for its one frame, vismapd one per session's scene,
// whichever renderer draws its frames.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>

#include "core/facts/scene_facts.h"
#include "core/scene.h"
#include "core/surfaces/tessellate.h"

namespace vismap::frame {

// When a frame takes the scene's facts: from the scene's second frame on (Repeat: a single
// frame, as the CLI renders, does not pay for them; an orbit does), from the first (Now), only
// once someone found them (Found: vismapd finds them on its load pool, and frames go without
// until then), or never (Off). The map is the same either way. Under a memory budget Repeat
// finds none (the facts' device bytes would change the buckets' plan from the second frame on).
enum class FactsPolicy : uint8_t { Repeat, Now, Found, Off };

// The host bytes a scene holds (its meshes' arrays and names): what vismapd charges a session.
uint64_t scene_bytes(const Scene& scene);

class SceneState {
 public:
  explicit SceneState(std::shared_ptr<const Scene> scene);
  SceneState(const SceneState&) = delete;
  SceneState& operator=(const SceneState&) = delete;

  const std::shared_ptr<const Scene>& scene() const { return scene_; }
  uint64_t scene_bytes() const { return frame::scene_bytes(*scene_); }

  // The facts, once found (null before, and where none could be found).
  std::shared_ptr<const facts::SceneFacts> facts() const;
  // Finds them, once (a second call returns what the first found): for a scene of meshes only
  // (a scene with curved surfaces is diced anew every frame), where the search fits the memory
  // budget (facts::scene_facts_fit; 0: none), within max_seconds (0: none). Kept only where the
  // scene and its facts together hold at most keep_bytes (0: any). Safe from any thread; a
  // frame meanwhile goes without.
  std::shared_ptr<const facts::SceneFacts> find_facts(uint64_t memory_budget, double max_seconds,
                                                      uint64_t keep_bytes = 0);
  // Counts a frame begun; returns how many began before it.
  uint64_t begin_frame() { return frames_.fetch_add(1); }

  // The Loop plans of the scene's subdivision surfaces, kept for its next frame (used by one
  // frame at a time: a session renders its frames one after another).
  LoopPlans& loop_plans() { return loop_plans_; }

 private:
  const std::shared_ptr<const Scene> scene_;
  mutable std::mutex mu_;
  std::shared_ptr<const facts::SceneFacts> facts_;
  bool facts_tried_ = false;
  std::atomic<uint64_t> frames_{0};
  LoopPlans loop_plans_;
};

}  // namespace vismap::frame
