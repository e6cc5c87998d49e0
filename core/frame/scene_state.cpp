#include "core/frame/scene_state.h"

namespace vismap::frame {

SceneState::SceneState(std::shared_ptr<const Scene> scene) : scene_(std::move(scene)) {}

uint64_t scene_bytes(const Scene& scene) {
  uint64_t b = sizeof(Scene);
  for (const Mesh& m : scene.meshes)
    b += sizeof(Mesh) + m.name.size() +
         4 * (m.positions.size() + m.indices.size() + m.face_ids.size());
  return b;
}

std::shared_ptr<const facts::SceneFacts> SceneState::facts() const {
  std::lock_guard lk(mu_);
  return facts_;
}

std::shared_ptr<const facts::SceneFacts> SceneState::find_facts(uint64_t memory_budget,
                                                                double max_seconds,
                                                                uint64_t keep_bytes) {
  {
    std::lock_guard lk(mu_);
    if (facts_tried_) return facts_;
    facts_tried_ = true;
  }
  if (scene_->has_surfaces() ||
      !facts::scene_facts_fit(scene_->triangle_count(), memory_budget))
    return nullptr;
  auto f = std::make_shared<const facts::SceneFacts>(facts::find_scene_facts(*scene_, max_seconds));
  if (!(f->cap > 0) || (keep_bytes && scene_bytes() + f->bytes() > keep_bytes)) return nullptr;
  std::lock_guard lk(mu_);
  facts_ = std::move(f);
  return facts_;
}

}  // namespace vismap::frame
