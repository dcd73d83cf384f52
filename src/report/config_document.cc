#include "report/config_document.h"

#include "blmd/report/report.h"
#include "blmd/sim/effects.h"

namespace blmd {

using nlohmann::json;

json ConfigDocumentOf(const Config& config) {
  json doc = config.document.is_object() ? config.document : json::object();
  doc["model"] = std::string(config.model->name());
  return doc;
}

void SetModelValues(const Config& config, const ParameterSet& values, json* doc) {
  json parameters = json::object();
  for (const auto& info : config.model->parameters()) {
    if (values.Has(info.name)) parameters[info.name] = values.Get(info.name);
  }
  (*doc)["parameters"] = parameters;
  json effects = json::object();
  for (const auto& name : config.effects) {
    json effect = json::object();
    for (const auto& p : FindEffect(name).parameters) effect[p.config_key()] = values.Get(p.name);
    effects[name] = effect;
  }
  if (effects.empty()) {
    doc->erase("effects");
  } else {
    (*doc)["effects"] = effects;
  }
}

void SetNotes(const Config& config, json notes, json* doc) {
  if (!config.notes.is_null()) notes["config_notes"] = config.notes;
  (*doc)["notes"] = std::move(notes);
  SanitizeJson(doc);
}

}  // namespace blmd
