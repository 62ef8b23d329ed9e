// Blender's camera as Cycles builds it (intern/cycles/blender/camera.cpp: the view plane
// from sensor fit, aspect, ortho scale and shift; scene/camera.cpp: the projection).
//
// Raster coordinates are Cycles' (x right, y UP from the bottom row, pixel centres at
// i + 0.5). The returned image is stored top row first; `pixel_row_to_raster_y` converts.
// Camera space: x right, y up, z forward (Blender's local -Z); the world matrix is the
// camera object's with its scale removed, as Cycles does.
#pragma once

#include "hairbsdf/render/geometry.h"

namespace hairbsdf::render {

class Camera {
public:
    explicit Camera(const CameraDesc& desc);

    int width() const { return width_; }
    int height() const { return height_; }

    // The primary ray through raster position (x, y). Direction is unit length; tmin/tmax
    // are the clip distances along it (clipping planes perpendicular to the view axis).
    Ray generate(double raster_x, double raster_y) const;

    // Camera-space depth of a world point: its distance along the view axis.
    double depth(Vec3 p) const { return dot(p - origin_, axis_z_); }

    // Image row (0 = top) -> Cycles raster row (0 = bottom).
    int pixel_row_to_raster_y(int row) const { return height_ - 1 - row; }

    // The view plane in Cycles' screen units (before the perspective tan(fov / 2)).
    double left() const { return left_; }
    double right() const { return right_; }
    double bottom() const { return bottom_; }
    double top() const { return top_; }

private:
    CameraType type_;
    int width_, height_;
    double left_ = -1, right_ = 1, bottom_ = -1, top_ = 1;
    double tan_half_fov_ = 1;
    double clip_start_, clip_end_;
    Vec3 origin_, axis_x_, axis_y_, axis_z_;  // camera-to-world, orthonormal
};

}  // namespace hairbsdf::render
