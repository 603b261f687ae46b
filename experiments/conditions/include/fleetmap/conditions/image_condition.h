// An appearance condition of real camera images: how the camera that recorded a stereo pair in
// daylight would have recorded the same scene at another hour and in other weather, as the
// parameters of five effects of image formation. condition_schedule.h resolves them from an
// hour and a weather; apply_condition.h renders a pair with them.
//
// Conventions:
// - "Linear" values are proportional to the light that reached the sensor. 1 is the light that
//   made an 8-bit 255 in the recording (its full scale at its exposure). The 8-bit recording is
//   linearised with the sensor's encoding gamma, linear = (value / 255)^encoding_gamma, and the
//   rendering is encoded back the same way after the condition's tone curve.
// - The camera is level and looks along the direction of travel (a car's or a robot's forward
//   camera): the focus of expansion of forward motion is the principal point (cx, cy), and a
//   direction of elevation e and azimuth a (right of the optical axis) is the ray
//   (cos e sin a, -sin e, cos e cos a) in the camera frame (x right, y down, z forward).
// - Depth z along the optical axis in metres, from the pair itself (stereo_disparity.h).
// - Times in seconds, angles in degrees, extinction in 1/m.
//
// The rendering of one image, in the order light meets the camera:
//   scene -> haze (4, the air) -> motion blur (3, the hazed view sliding over the sensor)
//   -> light level and exposure (1) -> glare (5, inside the lens) -> shot and read noise (2)
//   -> gain (1) -> tone curve, 8-bit quantisation and clipping (1).
// A default-constructed ImageCondition is the identity (noon in sun: the recording itself).
#pragma once

#include <string>

#include "fleetmap/conditions/stereo_disparity.h"
#include "fleetmap/world/world.h"

namespace fleetmap {

// 1. Exposure and tone. The scene's light is light_level times the recording's; the camera
// collects it for exposure_s instead of recording_exposure_s and amplifies it by gain over the
// recording's gain, so the rendered linear value is
//   linear x light_level x (exposure_s / recording_exposure_s) x gain
// before noise. Auto-exposure (condition_schedule.h) picks exposure_s and gain to bring the
// image back to the recording's brightness when the limits allow; a dim scene beyond them stays
// dim. The tone curve raises the encoded value (in [0, 1]) to tone_gamma: above 1 it darkens
// mid-tones and crushes shadows, as a camera's low-light tone curve and black clamp do.
struct ExposureEffect {
  double encoding_gamma = 2.2;          // the recording's 8-bit encoding, [1, 3]; 1 is linear
  double light_level = 1.0;             // scene illuminance / the recording's, (0, 100]
  double recording_exposure_s = 0.002;  // the recording's exposure time, (0, 1]
  double exposure_s = 0.002;            // this condition's exposure time, (0, 1]
  double gain = 1.0;                    // analogue gain over the recording's, (0, 1000]
  double tone_gamma = 1.0;              // exponent on the encoded value, [0.25, 4]

  // Photons collected per pixel relative to the recording: light_level x exposure ratio.
  double photon_fraction() const { return light_level * exposure_s / recording_exposure_s; }
  // The rendered linear value per recorded one (before noise and clipping).
  double brightness_factor() const { return photon_fraction() * gain; }

  friend bool operator==(const ExposureEffect&, const ExposureEffect&) = default;
};

// 2. Low light: shot and read noise. A pixel of linear value L (after blur and haze) expects
// mu = L x photon_fraction x full_scale_electrons photo-electrons (plus the glare's); the sensor
// counts Poisson(mu) of them (drawn exactly below 30 expected, from the normal approximation
// N(mu, mu) above, where the Poisson's skew is under 0.19), adds Gaussian read noise of
// read_noise_electrons rms, and the gain scales the count back up. Noise is drawn only when the
// condition collects fewer photons than the recording (photon_fraction < 1): the recording's
// own noise, scaled down with its signal, stands for the noise of a brighter exposure, and is
// small beside the fresh noise once photon_fraction is well below 1.
struct SensorNoiseEffect {
  // Electrons behind a linear 1 (an 8-bit 255) in the recording: the sensor's full well at the
  // recording's gain. 0 (an ideal sensor: no noise) or [10, 1e7].
  double full_scale_electrons = 10000.0;
  double read_noise_electrons = 5.0;  // rms, [0, 10000]

  friend bool operator==(const SensorNoiseEffect&, const SensorNoiseEffect&) = default;
};

// 3. Motion blur. Moving forward at v m/s, a point at depth z seen at pixel (u, v) slides away
// from the focus of expansion by (u - cx, v - cy) x travel / z during the exposure, where
// travel = v x (exposure_s - recording_exposure_s): the recording already holds the blur of its
// own exposure, so only the longer exposure's extra streak is added (none when exposure_s is not
// longer). Each pixel is averaged over its streak, centred on it (the exposure's midpoint is
// where the recording saw the scene), from evenly spaced bilinear samples along the flow: about
// one per pixel of the longest streak, a power of 3 up to max_samples (they are averaged in
// rounds of three). The sky, at infinite depth, does not move.
struct MotionBlurEffect {
  int max_samples = 27;        // samples along the longest streak at most, [3, 243]
  double min_streak_px = 0.5;  // a longest streak shorter than this adds no blur, [0, 100]

  friend bool operator==(const MotionBlurEffect&, const MotionBlurEffect&) = default;
};

// 4. Haze. Light from depth z crosses z metres of air that scatters it out and scatters
// ambient light in: I = I0 e^{-beta z} + A (1 - e^{-beta z}), with beta the extinction
// coefficient (meteorological visibility is 3.912 / beta) and A the airlight, the brightness of
// the horizon sky in the recording's linear units. Both are then lit by the condition's light
// level. The sky (no disparity) takes A.
struct HazeEffect {
  double extinction_per_m = 0.0;  // beta, [0, 1]; 0 is clear air (the recording's)
  double airlight = 0.8;          // A, linear, [0, 4]

  friend bool operator==(const HazeEffect&, const HazeEffect&) = default;
};

// 5. Veiling glare of a low sun. Light scattered inside the lens from a bright source adds a
// broad halo around it, falling off with the angle theta from the source, and a uniform veil
// that lowers contrast everywhere:
//   glare(theta) = peak / (1 + (theta / core_deg)^2) + veil,
// added to the linear image at the condition's exposure (after gain: 1 is full scale). The sun
// is at infinity, so it falls on the same pixel of both rectified images, in the frame or
// beyond its edge.
struct GlareEffect {
  double peak = 0.0;               // at the sun's direction, linear, [0, 10]
  double core_deg = 4.0;           // where the halo is half its peak, (0, 90]
  double veil = 0.0;               // uniform, linear, [0, 1]
  double sun_azimuth_deg = 20.0;   // right of the optical axis, [-180, 180]
  double sun_elevation_deg = 5.0;  // above the horizon, [-90, 90]

  friend bool operator==(const GlareEffect&, const GlareEffect&) = default;
};

struct ImageCondition {
  std::string name = "day-sun";  // e.g. "dawn-sun", "night-rain" (condition_schedule.h)
  double hour_of_day = 12.0;     // the local hour it was resolved for, [0, 24)
  Weather weather = Weather::kSun;
  ExposureEffect exposure;
  SensorNoiseEffect noise;
  MotionBlurEffect blur;
  HazeEffect haze;
  GlareEffect glare;
  StereoDisparityOptions depth;  // how haze and blur find depth

  friend bool operator==(const ImageCondition&, const ImageCondition&) = default;
};

// Throws Error(kInvalidArgument) naming the first field out of its range above, e.g.
// "image condition: haze.extinction_per_m must be in [0, 1], got 2".
void ValidateImageCondition(const ImageCondition& condition);

// True when the condition changes nothing (ApplyCondition returns the input bit for bit at any
// speed): brightness factor 1 and no fewer photons than the recording (within 1e-9), tone 1, no
// exposure longer than the recording's, clear air and no glare.
bool IsIdentityCondition(const ImageCondition& condition);

}  // namespace fleetmap
