// A model overlay (model/overlay.h) as the truth of a simulation: `boresight simulate --overlay FILE`.
//
// The overlay is what a program learnt about the instruments (audit --write-model, calibrate
// --write-model); simulating it beside the data it was learnt from closes the loop: the simulation of
// the extended model should look like the data. The overlay is laid over the scenario, item by item,
// and replaces what the scenario says about the same thing (it never adds to it):
//   - mountings: a head's q_Si_B becomes its true constant mounting (mounting_error_rad relative to the
//     scenario's nominal q_Si_B); the scenario's random mounting error (mounting_error_sigma) is turned
//     off and the relative_misalignment specs of that head are dropped. The simulated body frame is the
//     overlay's datum (an accelerometer datum is the simulator's own B; a star-camera datum makes the
//     heads' mean frame the body frame the accelerometer is aligned with).
//   - noise: a head axis's model becomes its whole random error: the white term sets the head's level
//     (the scenario's cross_noise / anisotropic_noise specs of the head dropped), every Gauss-Markov or
//     power-law term becomes a coloured_noise spec (the scenario's coloured_noise on that axis dropped;
//     its fov_error and thermal_wander specs too when the overlay gives both cross axes and the
//     boresight axis). The simulator draws both cross-boresight axes alike: with cross_x and cross_y
//     different it uses their RMS per term (named). Star directions: the white level. Accelerometer
//     axes: the white level, the coloured terms as acc_coloured_noise specs (the scenario's
//     low-frequency noise, acc_coloured_noise and acc_bias_wander on that axis dropped).
//   - thermal: each non-datum head's deformation delta_k (in the datum head's frame) becomes rotations
//     of that head's mounting, phi_k = -C0_k,d delta_k (the first-order inverse of the overlay's form,
//     core/thermal_harmonics.h): the constant as a relative_misalignment, every harmonic as one
//     thermal_periodic spec per head axis (amplitude and phase from cos and sin), a beta harmonic as a
//     pair of specs whose sum is its (cos beta - cos beta_ref) term. The scenario's thermal_periodic
//     specs are dropped.
//   - accelerometer: bias, scale, misalignment as acc_bias, acc_scale, acc_misalignment (the
//     scenario's specs of those kinds dropped, and with a bias its nominal bias too: the overlay's is
//     the whole bias a program subtracts from the measurement); a non-zero non-orthogonality is not simulated (named).
//   - time offsets: an accelerometer or head offset against the heads or GPS as a time_offset spec of
//     that sensor (the scenario's time_offset specs of that sensor dropped); an offset against the
//     heads adds the heads' own offset from a scenario spec on 'all'.
//   - published_frame: not a model of the instruments (named as not applied).
// Every spec made carries the origin "overlay FILE: ITEM" (so truth.yaml says where it came from); an
// item whose validity does not cover the simulated span is applied over the whole span, with a note.
#pragma once

#include <boresight/model/overlay.h>
#include <boresight/sim/scenario.h>

#include <string>
#include <vector>

namespace boresight::sim {

/// What applyOverlay did, for the program's output: one line per item.
struct ScenarioOverlayUse {
  std::vector<std::string> applied;      ///< "mountings: head 2 (star_cameras datum)", ...
  std::vector<std::string> replaced;     ///< the scenario's items the overlay replaced ("relative_misalignment on head 2 (x.yaml: effects[0])")
  std::vector<std::string> not_applied;  ///< with the reason
  std::vector<std::string> notes;        ///< approximations and validity spans
};

/// Lays `ov` (read from `source`, which names it in origins and messages) over `sc` for a simulation
/// of `duration_s` seconds from sc.start. False with *error when a spec cannot be made (e.g. a time
/// offset beyond the simulator's +-2 s, a thermal datum head the scenario does not have).
bool applyOverlay(const model::Overlay& ov, const std::string& source, double duration_s, Scenario& sc,
                  ScenarioOverlayUse& use, std::string* error);

}  // namespace boresight::sim
