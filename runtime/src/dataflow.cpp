#include "regolith/runtime/dataflow.hpp"

#include <algorithm>
#include <cstdlib>
#include <functional>
#include <map>
#include <memory>
#include <ostream>
#include <set>

#include <cxxabi.h>

#include "regolith/core/error.hpp"

namespace regolith::runtime {
namespace {

using Kind = Port::Kind;

[[noreturn]] void fail(const Port& at, const std::string& problem) {
  throw ConfigError(at.where + ": components." + at.component + ": " + problem);
}

std::string quoted_list(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "'" : ", '") + x + "'";
  return s;
}

/// Graphviz ID: a double-quoted string with quotes and backslashes escaped.
std::string dot_id(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

std::string type_name(const std::type_info& t) {
  int status = 0;
  std::unique_ptr<char, void (*)(void*)> d(abi::__cxa_demangle(t.name(), nullptr, nullptr, &status), std::free);
  return status == 0 && d ? std::string(d.get()) : std::string(t.name());
}

void DataFlowGraph::check() const {
  // Producers per channel: exactly one, and consumers read its type.
  std::map<std::string, const Port*> producer;
  for (const auto& p : ports) {
    if (p.kind != Kind::kProduces) continue;
    auto [it, fresh] = producer.emplace(p.name, &p);
    if (!fresh) {
      if (it->second->component == p.component) continue;  // declared twice by one component
      fail(p, "produces channel '" + p.name + "', which '" + it->second->component +
                  "' already produces: a channel has exactly one producer");
    }
  }
  for (const auto& p : ports) {
    if (p.kind != Kind::kConsumes) continue;
    const auto it = producer.find(p.name);
    if (it == producer.end()) {
      std::vector<std::string> channels;
      for (const auto& kv : producer) channels.push_back(kv.first);
      fail(p, "consumes channel '" + p.name + "' (" + p.type + "), which no component of this deployment produces" +
                  (channels.empty() ? std::string() : " (produced here: " + quoted_list(channels) + ")"));
    }
    if (it->second->type != p.type)
      fail(p, "consumes channel '" + p.name + "' as " + p.type + " but '" + it->second->component + "' produces " +
                  it->second->type);
  }
  // Component graph: producer -> consumer. No cycles (depth-first search with colours).
  std::map<std::string, std::set<std::string>> next;
  std::map<std::string, const Port*> first_port;
  for (const auto& p : ports) {
    first_port.emplace(p.component, &p);
    if (p.kind == Kind::kConsumes) next[producer.at(p.name)->component].insert(p.component);
  }
  std::map<std::string, int> colour;  // 0 white, 1 on the stack, 2 done
  std::vector<std::string> stack;
  std::function<void(const std::string&)> visit = [&](const std::string& c) {
    colour[c] = 1;
    stack.push_back(c);
    for (const auto& n : next[c]) {
      if (colour[n] == 1) {
        std::string cycle;
        for (auto i = std::find(stack.begin(), stack.end(), n); i != stack.end(); ++i) cycle += *i + " -> ";
        fail(*first_port.at(n), "data-flow cycle " + cycle + n +
                                    ": each component would read what it wrote a cycle earlier; break the loop");
      }
      if (colour[n] == 0) visit(n);
    }
    stack.pop_back();
    colour[c] = 2;
  };
  for (const auto& kv : first_port)
    if (colour[kv.first] == 0) visit(kv.first);
  // Within one rate group a consumer runs after its producer (else it reads the previous cycle).
  for (const auto& g : groups) {
    for (std::size_t i = 0; i < g.members.size(); ++i) {
      for (const auto& p : ports) {
        if (p.kind != Kind::kConsumes || p.component != g.members[i]) continue;
        const std::string& prod = producer.at(p.name)->component;
        const auto at = std::find(g.members.begin(), g.members.end(), prod);
        if (at != g.members.end() && static_cast<std::size_t>(at - g.members.begin()) > i)
          fail(p, "runs before '" + prod + "', the producer of '" + p.name + "', in rate group '" + g.name +
                      "': it would read the previous cycle's value; list '" + prod + "' first in members");
      }
    }
  }
}

void DataFlowGraph::print(std::ostream& os) const {
  std::map<std::string, std::vector<const Port*>> consumers;
  for (const auto& p : ports)
    if (p.kind == Kind::kConsumes) consumers[p.name].push_back(&p);
  os << "# data flow (producer --channel [payload]--> consumers)\n";
  for (const auto& p : ports) {
    if (p.kind != Kind::kProduces) continue;
    os << p.component << " --" << p.name << " [" << p.type << "]--> ";
    const auto it = consumers.find(p.name);
    if (it == consumers.end()) {
      os << "(no consumer)";
    } else {
      for (std::size_t i = 0; i < it->second.size(); ++i) os << (i ? ", " : "") << it->second[i]->component;
    }
    os << "\n";
  }
  for (const auto& p : ports) {
    if (p.kind != Kind::kDevice) continue;
    if (p.type == "calibration")
      os << "camera " << p.name << " (calibration) --> " << p.component << "\n";
    else
      os << p.type << " " << p.name << " --> " << p.component << "\n";
  }
}

void DataFlowGraph::print_dot(std::ostream& os) const {
  os << "digraph regolith {\n  rankdir=LR;\n  node [fontname=\"Helvetica\"];\n";
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    os << "  subgraph " << dot_id("cluster_" + groups[gi].name)
       << " {\n    label=" << dot_id("rate group " + groups[gi].name) << ";\n    style=rounded;\n";
    for (const auto& m : groups[gi].members) os << "    " << dot_id(m) << " [shape=box];\n";
    os << "  }\n";
  }
  // Devices as inputs; a camera whose calibration is read (not its frames) gets a dashed edge.
  std::set<std::string> devices, frame_edges;
  for (const auto& p : ports)
    if (p.kind == Kind::kDevice && p.type != "calibration") frame_edges.insert(p.name + ">" + p.component);
  for (const auto& p : ports) {
    if (p.kind != Kind::kDevice) continue;
    const bool calibration = p.type == "calibration";
    if (calibration && frame_edges.count(p.name + ">" + p.component)) continue;
    const std::string kind = calibration ? "camera" : p.type;
    const std::string id = kind + ":" + p.name;
    if (devices.insert(id).second)
      os << "  " << dot_id(id) << " [shape=ellipse, label=" << dot_id(kind + " " + p.name) << "];\n";
    os << "  " << dot_id(id) << " -> " << dot_id(p.component)
       << (calibration ? " [style=dashed, label=\"calibration\"]" : "") << ";\n";
  }
  std::map<std::string, const Port*> producer;
  for (const auto& p : ports)
    if (p.kind == Kind::kProduces) producer.emplace(p.name, &p);
  for (const auto& p : ports) {
    if (p.kind != Kind::kConsumes) continue;
    const auto it = producer.find(p.name);
    if (it == producer.end()) continue;
    os << "  " << dot_id(it->second->component) << " -> " << dot_id(p.component) << " [label=" << dot_id(p.name)
       << "];\n";
  }
  os << "}\n";
}

}  // namespace regolith::runtime
