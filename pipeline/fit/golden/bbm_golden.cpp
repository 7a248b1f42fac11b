// Golden values of two comparison models of `twoscale fit --compare` (pipeline/fit/src/compare/), by the
// reference implementation: bsdfbenchmark/bbm's headers on its `native` backbone, in double precision.
//
// - low_smooth: bbm::lowsmooth (include/bsdfmodel/lowsmooth.h) plus a Lambertian albedo / pi;
// - he: bbm::heholzschuch (include/bsdfmodel/he.h: the errata's Eq. 25, He et al.'s Eq. 78, 4 Newton steps,
//   10 Taylor terms) plus a Lambertian albedo / pi, each channel at the wavelength below.
//
// Built and run by bbm_golden.sh, which writes bbm.json; only that file's numbers are committed.
#include <cmath>
#include <cstdio>
#include <vector>

#include "bbm/bbm_core.h"
#include "bsdfmodel/he.h"
#include "bsdfmodel/lowsmooth.h"

// The channels' wavelengths in micrometres (`twoscale fit`'s default --wavelengths): He's sigma and tau
// are in the same unit.
struct golden : public bbm::detail::rgbConfig<double, "golden", golden> {
  static Spectrum wavelength(void) { return {0.65, 0.55, 0.45}; }
};
using Spectrum = golden::Spectrum;
using Vec3 = bbm::vec3d<double>;

struct Pair { Vec3 wi, wo; };

static Vec3 direction(double theta, double phi) {
  return Vec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
}

// 64 direction pairs: near the normal, mirror pairs in the plane of incidence (where the lobes peak),
// pairs near the mirror direction, grazing ones, and pairs spread over the hemisphere by a fixed
// sequence. None has wi = wo or a direction at the normal, where BBM's Eq. 76 takes 1 or 0 / 0 for a
// factor that is 1 (pipeline/fit/src/compare/he.rs, `geometrical`).
static std::vector<Pair> pairs() {
  std::vector<Pair> out;
  out.push_back({direction(0.01, 0), direction(0.02, M_PI)});
  for (double t : {0.2, 0.6, 1.0, 1.3, 1.5}) out.push_back({direction(t, 0), direction(t, M_PI)});
  for (double t : {0.3, 0.9, 1.4}) {
    for (double d : {0.01, 0.05, 0.15}) out.push_back({direction(t, 0), direction(t + d, M_PI + d)});
  }
  for (double t : {1.45, 1.52, 1.56}) out.push_back({direction(t, 0), direction(0.7, 2.0)});
  // Weyl's sequence in (cos^2 theta, phi) for both directions
  const double a[4] = {0.7548776662466927, 0.5698402909980532, 0.4301597090019468, 0.2451223337533073};
  for (int n = 1; out.size() < 64; ++n) {
    double u[4];
    for (int k = 0; k < 4; ++k) u[k] = std::fmod(0.5 + n * a[k], 1.0);
    double ti = std::acos(std::sqrt(0.02 + 0.98 * u[0])), to = std::acos(std::sqrt(0.02 + 0.98 * u[2]));
    out.push_back({direction(ti, 2 * M_PI * u[1]), direction(to, 2 * M_PI * u[3])});
  }
  return out;
}

static void print_vec(const Vec3& v) { std::printf("[%.17g, %.17g, %.17g]", v[0], v[1], v[2]); }

static void print_values(const std::vector<Spectrum>& values) {
  std::printf("[");
  for (size_t n = 0; n < values.size(); ++n) {
    const Spectrum& s = values[n];
    std::printf("%s[%.17g, %.17g, %.17g]", n ? ", " : "", s[0], s[1], s[2]);
  }
  std::printf("]");
}

// The model's eval plus a Lambertian albedo kd / pi, at every pair.
template <typename Model>
static std::vector<Spectrum> with_lambertian(const Model& model, const double kd[3], const std::vector<Pair>& ps) {
  std::vector<Spectrum> values;
  for (const Pair& q : ps) {
    Spectrum v = model.eval(q.wi, q.wo);
    for (int ch = 0; ch < 3; ++ch) v[ch] += kd[ch] * (1.0 / M_PI);
    values.push_back(v);
  }
  return values;
}

int main() {
  const std::vector<Pair> ps = pairs();
  std::printf("{\n  \"source\": \"bsdfbenchmark/bbm (pipeline/fit/golden/bbm_golden.sh names the commit), native backbone, double\",\n");
  std::printf("  \"wavelengths\": [0.65, 0.55, 0.45],\n  \"directions\": [");
  for (size_t n = 0; n < ps.size(); ++n) {
    std::printf("%s[", n ? ", " : "");
    print_vec(ps[n].wi);
    std::printf(", ");
    print_vec(ps[n].wo);
    std::printf("]");
  }
  std::printf("],\n");

  // low_smooth: kd and A per channel, B, C, eta
  struct Low { double kd[3], a[3], b, c, eta; };
  const Low lows[3] = {
    {{0.1, 0.2, 0.3}, {50, 80, 120}, 300, 1.2, 1.5},
    {{0.0, 0.05, 0.01}, {2, 3, 4}, 10, 0.5, 3.0},
    {{0.3, 0.3, 0.3}, {5000, 4000, 3000}, 1e5, 2.5, 1.2},
  };
  std::printf("  \"low_smooth\": [");
  for (int s = 0; s < 3; ++s) {
    const Low& p = lows[s];
    bbm::lowsmooth<golden> model;
    model.A = Spectrum(p.a[0], p.a[1], p.a[2]);
    model.B = p.b;
    model.C = p.c;
    model.eta = p.eta;
    const std::vector<Spectrum> values = with_lambertian(model, p.kd, ps);
    std::printf("%s\n    {\"kd\": [%.17g, %.17g, %.17g], \"A\": [%.17g, %.17g, %.17g], \"B\": %.17g, \"C\": %.17g, \"eta\": %.17g,\n     \"rho\": ",
                s ? "," : "", p.kd[0], p.kd[1], p.kd[2], p.a[0], p.a[1], p.a[2], p.b, p.c, p.eta);
    print_values(values);
    std::printf("}");
  }
  std::printf("],\n");

  // he: sigma and tau (micrometres), eta, k and kd per channel
  struct He { double sigma, tau, eta[3], k[3], kd[3]; };
  const He hes[3] = {
    {0.18, 3.0, {0.2, 0.4, 1.2}, {3.5, 2.6, 1.9}, {0, 0, 0}},
    {0.05, 1.0, {1.5, 1.5, 1.5}, {0, 0, 0}, {0.2, 0.1, 0.05}},
    {0.3, 5.0, {2.9, 2.9, 2.8}, {3.0, 3.0, 3.1}, {0.02, 0.02, 0.02}},
  };
  std::printf("  \"he\": [");
  for (int s = 0; s < 3; ++s) {
    const He& p = hes[s];
    bbm::heholzschuch<golden> model;
    model.roughness = p.sigma;
    model.autocorrelation = p.tau;
    model.eta = bbm::complex<Spectrum>(Spectrum(p.eta[0], p.eta[1], p.eta[2]), Spectrum(p.k[0], p.k[1], p.k[2]));
    const std::vector<Spectrum> values = with_lambertian(model, p.kd, ps);
    std::printf("%s\n    {\"sigma\": %.17g, \"tau\": %.17g, \"eta\": [%.17g, %.17g, %.17g], \"k\": [%.17g, %.17g, %.17g], \"kd\": [%.17g, %.17g, %.17g],\n     \"rho\": ",
                s ? "," : "", p.sigma, p.tau, p.eta[0], p.eta[1], p.eta[2], p.k[0], p.k[1], p.k[2], p.kd[0], p.kd[1], p.kd[2]);
    print_values(values);
    std::printf("}");
  }
  std::printf("]\n}\n");
}
