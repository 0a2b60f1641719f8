// The admission rule, in one place: which points the analyses, the studies' reports and their
// conclusions use, from the runs' verdicts and the number of replicas behind a point.
#pragma once

#include <optional>
#include <string>

namespace jamflow::analysis {

// A point's verdicts as a table or a run summary holds them: passed, failed (in some replica),
// or not checked (nullopt).
struct PointVerdicts {
  std::optional<bool> steady, stable, decorrelated;
  double replicas = 1.0;  // replicas averaged into the point (0 or NaN: not known, taken as one)
};

struct Admission {
  bool admitted = true;
  // Why it is left out ("not steady, not decorrelated (one replica)"); "" when admitted.
  std::string reason;
  // Admitted although its blocks are shorter than 2 tau (not decorrelated): its error rests on
  // its replicas (their scatter from 3 on; with 2 the block error, which understates it).
  bool short_blocks = false;
};

// Left out: not steady or not stable, or not decorrelated with fewer than 2 replicas (its block
// error understates the error and no replicas' scatter can stand in). Everything else is
// admitted. A verdict not checked does not count against the point.
inline Admission admit(const PointVerdicts& v) {
  Admission a;
  auto add = [&](const char* why) { a.reason.append(a.reason.empty() ? "" : ", ").append(why); };
  if (v.steady == false)
    add("not steady");
  if (v.stable == false)
    add("not stable");
  if (v.decorrelated == false) {
    if (!(v.replicas >= 2.0))  // NaN, a count not known, is one replica
      add("not decorrelated (one replica)");
    else
      a.short_blocks = true;
  }
  a.admitted = a.reason.empty();
  return a;
}

}  // namespace jamflow::analysis
