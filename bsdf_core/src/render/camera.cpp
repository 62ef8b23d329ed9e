// Camera rays with Cycles' view plane and projection; see render/camera.h.
#include "hairbsdf/render/camera.h"

namespace hairbsdf::render {

Camera::Camera(const CameraDesc& d)
    : type_(d.type), width_(d.width), height_(d.height), clip_start_(d.clip_start), clip_end_(d.clip_end) {
    // View plane (Blender's sync): fit the sensor to the larger side for AUTO.
    const double xratio = double(width_) * 1.0;
    const double yratio = double(height_) * d.pixel_aspect;
    bool horizontal_fit;
    double sensor_size;
    switch (d.sensor_fit) {
        case SensorFit::Auto:
            horizontal_fit = xratio > yratio;
            sensor_size = d.sensor_width;
            break;
        case SensorFit::Horizontal:
            horizontal_fit = true;
            sensor_size = d.sensor_width;
            break;
        default:
            horizontal_fit = false;
            sensor_size = d.sensor_height;
            break;
    }
    double aspect_ratio, ax, ay;
    if (horizontal_fit) {
        aspect_ratio = xratio / yratio;
        ax = aspect_ratio;
        ay = 1.0;
    } else {
        aspect_ratio = yratio / xratio;
        ax = 1.0;
        ay = aspect_ratio;
    }
    if (type_ == CameraType::Orthographic) {
        ax *= d.ortho_scale / (aspect_ratio * 2.0);
        ay *= d.ortho_scale / (aspect_ratio * 2.0);
        aspect_ratio = d.ortho_scale / 2.0;
    }
    const double dx = 2.0 * aspect_ratio * d.shift_x, dy = 2.0 * aspect_ratio * d.shift_y;
    left_ = -ax + dx;
    right_ = ax + dx;
    bottom_ = -ay + dy;
    top_ = ay + dy;
    // Perspective: fov = 2 atan(0.5 sensor / lens / aspect_ratio); screen = camera xy / (z tan(fov/2)).
    tan_half_fov_ = 0.5 * sensor_size / d.lens / aspect_ratio;

    // Camera to world: Blender's matrix times scale(1, 1, -1), scale removed.
    const auto& m = d.matrix_world;  // row-major
    auto column = [&](int c) { return Vec3{m[c], m[4 + c], m[8 + c]}; };
    axis_x_ = normalize(column(0));
    axis_y_ = normalize(column(1));
    axis_z_ = normalize(-1.0 * column(2));
    origin_ = column(3);
}

Ray Camera::generate(double raster_x, double raster_y) const {
    const double sx = left_ + (right_ - left_) * raster_x / double(width_);
    const double sy = bottom_ + (top_ - bottom_) * raster_y / double(height_);
    Ray ray;
    if (type_ == CameraType::Perspective) {
        const Vec3 pc = normalize(Vec3{sx * tan_half_fov_, sy * tan_half_fov_, 1.0});
        ray.org = origin_;
        ray.dir = normalize(pc.x * axis_x_ + pc.y * axis_y_ + pc.z * axis_z_);
        ray.tmin = clip_start_ / pc.z;
        ray.tmax = clip_end_ / pc.z;
    } else {
        ray.org = origin_ + sx * axis_x_ + sy * axis_y_;
        ray.dir = axis_z_;
        ray.tmin = clip_start_;
        ray.tmax = clip_end_;
    }
    return ray;
}

}  // namespace hairbsdf::render
