// Measurement switches of the Huang model, for lab/huang_measure.cpp only: they change what the
// model computes away from Cycles' semantics, so they stay out of HuangHairParams.
#pragma once

#include <algorithm>

#include "hairbsdf/models/huang.h"

namespace hairbsdf {

struct HuangLab {
    // The model with Cycles' Simpson steps over h (prepare() and eval_cycles_stochastic) divided
    // by `refinement` (>= 1; 1 is the plain model).
    static HuangHair with_simpson_refinement(const HuangHairParams& params, int refinement) {
        HuangHair model(params);
        model.simpson_refinement_ = std::max(refinement, 1);
        return model;
    }
    // The model without TRRT+'s shell proposal (trt_mis_point samples TRRT+'s internal normal as
    // Cycles does only): the rule before it, to measure what the proposal changes.
    static HuangHair without_trrt_shell(const HuangHairParams& params) {
        HuangHair model(params);
        model.trrt_shell_ = false;
        return model;
    }
    // TRRT+'s shell proposal (trt_mis_point) at the entry state of the node gamma and the entry disk
    // point (r1, angle1), for tests of its density; ok is false where nothing enters.
    struct ShellProbe {
        const HuangHair& m;
        HuangHair::EntryState e{};
        HuangHair::ShellFrame f{};
        bool ok = false;
        ShellProbe(const HuangHair& model, const HuangHair::ShadingPoint& sp, double gamma, double r1, double angle1)
            : m(model) {
            ok = m.entry_state(sp, gamma, r1, angle1, e) && e.cos_mi2 > 0.0;
            if (ok) f = m.trrt_shell_frame(e);
        }
        Vec3 sample(double u2, double u3) const { return m.trrt_shell_sample(f, u2, u3); }
        double density(Vec3 h) const { return m.trrt_shell_density(f, h); }
        Vec3 axis() const { return e.mwt; }        // -wt: the shell is a band of cosines to it
        Vec3 mesonormal() const { return e.wmt; }  // the internal mesonormal
        double lo() const { return m.trrt_shell_lo_; }
        double hi() const { return m.trrt_shell_hi_; }
    };
    // One point of the deterministic eval's TRT rule (trt_mis_point) at the node gamma whose Simpson
    // weight times |d gamma / dh| is `weight`, for the unit point u: TRT and TRRT+ in eval units.
    static void trt_point(const HuangHair& m, const HuangHair::ShadingPoint& sp, Vec3 O, double gamma, double weight,
                          const double (&u)[4], RGB& trt, RGB& trrt) {
        const Vec3 I = sp.I;
        const double final_scale = sp.norm * m.inv_eta_ * m.inv_eta_;
        const double trrt_scale = m.trrt_m_.eval(I.y, std::sqrt(I.x * I.x + I.z * I.z), O.y,
                                                 std::sqrt(O.x * O.x + O.z * O.z)) * kInvTwoPi * (2.0 / kPi) * sp.norm;
        m.trt_mis_point(sp, O, gamma, u[0], kTwoPi * u[1], u[2], u[3], 2.0 * u[0] * weight, trt, trrt);
        trt = (m.factors_[2] * final_scale) * trt;
        trrt = trrt_scale * trrt;
    }
};

}  // namespace hairbsdf
