#include "driver/run_status.hpp"

#include <array>

namespace jamflow {

namespace {

struct Word {
  RunStatus::Kind kind;
  std::string_view word;
  std::string_view separator;  // between the word and the detail
};

// budget, not run, aborted and unreadable were written with a colon after the word; the others with
// a space.
constexpr std::array<Word, 8> kWords{{
    {RunStatus::Kind::kComplete, "complete", " "},
    {RunStatus::Kind::kRunning, "running", " "},
    {RunStatus::Kind::kInterrupted, "interrupted", " "},
    {RunStatus::Kind::kFailed, "failed", " "},
    {RunStatus::Kind::kBudget, "budget", ": "},
    {RunStatus::Kind::kNotRun, "not run", ": "},
    {RunStatus::Kind::kAborted, "aborted", ": "},
    {RunStatus::Kind::kUnreadable, "unreadable", ": "},
}};

}  // namespace

std::string RunStatus::text() const {
  for (const Word& w : kWords)
    if (w.kind == kind)
      return detail.empty() ? std::string(w.word)
                            : std::string(w.word).append(w.separator).append(detail);
  return "unreadable: status kind " + std::to_string(static_cast<int>(kind));
}

RunStatus RunStatus::parse(std::string_view text) {
  for (const Word& w : kWords) {
    if (text.substr(0, w.word.size()) != w.word)
      continue;
    std::string_view rest = text.substr(w.word.size());
    if (!rest.empty() && rest[0] != ' ' && rest[0] != ':')
      continue;  // a longer word
    if (rest.substr(0, w.separator.size()) == w.separator)
      rest.remove_prefix(w.separator.size());
    else
      while (!rest.empty() && (rest[0] == ' ' || rest[0] == ':'))
        rest.remove_prefix(1);
    return {w.kind, std::string(rest)};
  }
  return unreadable(text.empty() ? std::string("no status")
                                 : "status \"" + std::string(text) + "\"");
}

}  // namespace jamflow
