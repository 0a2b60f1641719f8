// Outputs of the analyses: machine-readable JSON (every fitted quantity as
// {"value": v, "error": e}), a markdown report with tables, and the plot
// sidecar JSON read by the scripts in analysis/plots/.
#pragma once

#include <string>
#include <vector>

#include "analysis/hard_sphere.hpp"
#include "analysis/json.hpp"
#include "analysis/olsson_teitel.hpp"
#include "analysis/soft.hpp"

namespace jamflow::analysis {

Json measured_json(const Measured& m);

// What the input points' errors are made of (data.hpp PointErrors) as JSON.
Json point_errors_json(const PointErrors& e);

// The error model of one fit (error_model.hpp) as JSON.
Json error_model_json(const ErrorModel& m);

// "0.6474 ± 0.0012" with the error to two significant digits.
std::string format_measured(const Measured& m);

// Text for one markdown table cell: a '|' (as in "|t| <= 4") is escaped, so that it does not
// split the cell; one already escaped ("\\|") is kept as it is.
std::string markdown_cell(const std::string& text);

Json hard_sphere_json(const HardSphereResult& r, const HardSphereOptions& o,
                      const std::vector<std::string>& inputs);
std::string hard_sphere_markdown(const HardSphereResult& r, const HardSphereOptions& o,
                                 const std::vector<std::string>& inputs);
Json hard_sphere_plot_data(const HardSphereResult& r);

Json soft_json(const SoftResult& r, const SoftOptions& o, const std::vector<std::string>& inputs);
std::string soft_markdown(const SoftResult& r, const SoftOptions& o,
                          const std::vector<std::string>& inputs);
Json soft_plot_data(const SoftResult& r);
// The joint soft fit (and its yield-stress comparison, if any) as JSON, markdown and plot data.
Json joint_soft_json(const JointSoftFit& f, const YieldComparison* yield);
std::string joint_soft_markdown(const JointSoftFit& f, const YieldComparison* yield);
Json joint_soft_plot_data(const JointSoftFit& f, const YieldComparison* yield);

Json olsson_teitel_json(const OlssonTeitelResult& r, const OlssonTeitelOptions& o,
                        const std::vector<std::string>& inputs);
std::string olsson_teitel_markdown(const OlssonTeitelResult& r, const OlssonTeitelOptions& o,
                                   const std::vector<std::string>& inputs);
Json olsson_teitel_plot_data(const OlssonTeitelResult& r, const std::vector<ShearPoint>& points);

}  // namespace jamflow::analysis
