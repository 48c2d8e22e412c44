#pragma once
// Declared data flow. While a component configures it declares what it reads and writes: the
// devices it uses and, through Context::produce / Context::consume, the channels it writes and
// reads (name + payload type). Once every component is configured the loader links the graph and
// checks it before anything runs: every consumed channel has exactly one producer of the same
// payload type, the graph has no cycle, and a consumer in its producer's rate group runs after
// it. Violations are located ConfigErrors. `regolith config check FILE [--dot]` prints the graph.
#include <iosfwd>
#include <string>
#include <typeinfo>
#include <vector>

namespace regolith::runtime {

struct Port {
  enum class Kind { kProduces, kConsumes, kDevice };
  Kind kind = Kind::kConsumes;
  std::string component;  ///< component name
  std::string name;       ///< channel name, or the device name for kDevice
  std::string type;       ///< payload type (demangled), or the device kind ("camera", "encoders")
  std::string where;      ///< "file:line:col" of the component's section
};

/// Readable name of a C++ type ("regolith::sfs::DtmFrame").
std::string type_name(const std::type_info& t);

/// The deployment's components, rate groups and ports, as checked and printed.
struct DataFlowGraph {
  struct Group {
    std::string name;
    std::vector<std::string> members;  ///< in execution order
  };
  std::vector<Group> groups;
  std::vector<Port> ports;

  /// Every check above; throws ConfigError at the first violation (consumers without a producer,
  /// two producers, type mismatch, cycle, consumer ahead of its producer in one rate group).
  void check() const;
  /// One line per channel: "producer --name [type]--> consumer, ..." and the device inputs.
  void print(std::ostream& os) const;
  /// Graphviz: components as boxes grouped by rate group, devices as inputs, channels as edges.
  void print_dot(std::ostream& os) const;
};

}  // namespace regolith::runtime
