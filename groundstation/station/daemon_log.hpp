// teamscan-groundstation's messages on stderr: journal priorities (sd-daemon.h "<N>" prefixes) when stderr
// goes to the journal, plain text with the program's name otherwise.
#pragma once

#include <string>

namespace teamscan::station::daemon {

inline constexpr int kErr = 3;
inline constexpr int kWarning = 4;
inline constexpr int kInfo = 6;

void log(int priority, const std::string& text);

}  // namespace teamscan::station::daemon
