// Builder: pbrt-v1–v3 named-material scoping. pbrt-v3 keeps the named materials in the graphics
// state (src/core/api.cpp: GraphicsState::namedMaterials; pbrtAttributeBegin pushes the state,
// pbrtAttributeEnd restores it, ObjectBegin/End do the same, TransformBegin/End do not), so a
// name defined inside a block is gone after it and the same name may be defined again in
// another block; pbrtMakeNamedMaterial replaces an existing entry without a warning.
// pbrtNamedMaterial only records the name; the Shape looks it up in its own scope
// (GraphicsState::CreateMaterial) and, when it is not there, uses the current Material.
// pbrt-v4 keeps one global table (scene/builder.cpp), which lensim uses for pbrt-v4 files.
#include "lensim/scene/build/builder_internal.h"

namespace lensim::scene::detail {

int Builder::namedMaterial(const std::string& name) const {
  if (scene_.legacy_syntax) {
    if (!gs_.scoped_materials) return -1;
    auto it = gs_.scoped_materials->find(name);
    return it == gs_.scoped_materials->end() ? -1 : it->second;
  }
  auto it = named_materials_.find(name);
  return it == named_materials_.end() ? -1 : it->second;
}

void Builder::makeNamedMaterialScoped(const Directive& d, Material m) {
  scene_.materials.push_back(std::move(m));
  const int index = static_cast<int>(scene_.materials.size()) - 1;
  auto table = gs_.scoped_materials
                   ? std::make_shared<std::map<std::string, int>>(*gs_.scoped_materials)
                   : std::make_shared<std::map<std::string, int>>();
  (*table)[d.strings[0]] = index;
  gs_.scoped_materials = std::move(table);
  named_materials_[d.strings[0]] = index;  // the last definition, for `lensim check`'s summary
}

void Builder::namedMaterialScoped(const Directive& d) {
  gs_.scoped_material_name = d.strings[0];
  gs_.scoped_material_loc = d.loc;
  gs_.material_name.clear();
}

}  // namespace lensim::scene::detail
