// ball.pov - scenes/ball.scene for POV-Ray 3.7 (the README's "PDS against
// POV-Ray"): a glass ball (IOR 1.5) resting on a diffuse floor (albedo
// 0.8) under a point light of 2000 W; caustics by POV-Ray's photon map.
//
// POV-Ray is left-handed: every z here is the scene's z negated, which
// mirrors nothing in the picture (the camera's right stays +x).
//
// Radiometry. PDS: a point light of power P has intensity I = P / (4 pi)
// and a Lambertian floor of albedo a reflects L = (a / pi) I cos(t) / r^2.
// POV-Ray: a light of colour C lights a surface of pigment p and finish
// "diffuse d" with C A(r) d p cos(t) (brilliance 1), where fade_power 2
// gives A(r) = 2 / (1 + (r / f)^2) = 2 f^2 / (f^2 + r^2) for fade_distance
// f. With d = 1, p = a and C = I / (2 pi f^2) the two agree up to the
// factor r^2 / (r^2 + f^2), 1 - 1.6e-8 here (f = 0.001, r > 5).
// No ambient (ambient_light 0, ambient 0), no specular highlight, linear
// output (assumed_gamma 1; write an .exr or .hdr).
//
// Set on the command line (declare=NAME=VALUE): Spacing (photon spacing
// at the ball, default 0.01) or Count (photons, overrides Spacing);
// GatherMax (most photons per estimate, default 0: POV-Ray's own choice);
// Collect=0 (the floor gathers no photons: the direct light alone, to
// check the radiometry against the reference's direct part).

#version 3.7;

#ifndef (Spacing) #declare Spacing = 0.01; #end
#ifndef (GatherMax) #declare GatherMax = 0; #end
#ifndef (Collect) #declare Collect = 1; #end

#declare P = 2000;                 // W, the scene's "power"
#declare I = P / (4 * pi);         // W/sr
#declare F = 0.001;                // fade_distance
#declare C = I / (2 * pi * F * F);

global_settings {
  assumed_gamma 1.0
  ambient_light rgb 0
  max_trace_level 16
  adc_bailout 0
  photons {
    #ifdef (Count) count Count #else spacing Spacing #end
    #if (GatherMax > 0) gather 20, GatherMax #end
    autostop 0
    max_trace_level 16
    adc_bailout 0
  }
}

camera {
  perspective
  location <0.8, 4.6, -4.4>
  look_at <-0.45, 0.4, 0.6>
  right x * 320 / 240
  up y
  // PDS's fov is vertical: 36 degrees over 240 rows; POV-Ray's angle is
  // horizontal
  angle 2 * degrees(atan(tan(radians(18)) * 320 / 240))
}

light_source {
  <5.6, 5.4, -3.7>
  color rgb C
  fade_distance F
  fade_power 2
  photons { refraction on reflection on }
}

// the floor: PDS's quad of 30 x 30 at y = 0
box {
  <-15, -1, -15>, <15, 0, 15>
  pigment { rgb 0.8 }
  finish { ambient 0 emission 0 diffuse 1 specular 0 phong 0 }
  photons { collect Collect }
}

// the ball: radius 1, its centre 1.001 above the floor
sphere {
  <0, 1.001, 0>, 1
  material {
    texture {
      pigment { rgbf 1 }
      finish { ambient 0 emission 0 diffuse 0 specular 0 phong 0
               reflection { 0, 1 fresnel on } conserve_energy }
    }
    interior { ior 1.5 }
  }
  photons { target 1.0 refraction on reflection on collect off }
}
