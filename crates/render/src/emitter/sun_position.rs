//! The sun's position for a date, time and place, as Mitsuba 0.6's `sun`/`sunsky` plugins compute it
//! (the PSA algorithm of Blanco-Muriel et al. 2001, `computeSunCoordinates` in Mitsuba's `sunsky.h`),
//! and the direction towards it in Mitsuba's Y-up local frame.

use glam::DVec3;

/// When and where the sun is observed (Mitsuba 0.6 `sunsky` parameters and their defaults).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunTimePlace {
    /// Calendar year (default 2010).
    pub year: i64,
    /// Month 1-12 (default 7).
    pub month: i64,
    /// Day of the month (default 10).
    pub day: i64,
    /// Local hour, fractional allowed (default 15).
    pub hour: f64,
    /// Minute (default 0).
    pub minute: f64,
    /// Second (default 0).
    pub second: f64,
    /// Latitude in degrees, north positive (default 35.6894, Tokyo).
    pub latitude: f64,
    /// Longitude in degrees, east positive (default 139.6917).
    pub longitude: f64,
    /// Time zone offset from UTC in hours (default 9).
    pub timezone: f64,
}

impl Default for SunTimePlace {
    fn default() -> Self {
        SunTimePlace {
            year: 2010,
            month: 7,
            day: 10,
            hour: 15.0,
            minute: 0.0,
            second: 0.0,
            latitude: 35.6894,
            longitude: 139.6917,
            timezone: 9.0,
        }
    }
}

/// The sun's zenith angle and azimuth in radians (azimuth measured from north towards east).
pub fn sun_zenith_azimuth(at: &SunTimePlace) -> (f64, f64) {
    use std::f64::consts::PI;
    let dec_hours = at.hour - at.timezone + (at.minute + at.second / 60.0) / 60.0;
    // Integer Julian day arithmetic as in the reference code (truncating division).
    let aux1 = (at.month - 14) / 12;
    let aux2 = (1461 * (at.year + 4800 + aux1)) / 4 + (367 * (at.month - 2 - 12 * aux1)) / 12
        - (3 * ((at.year + 4900 + aux1) / 100)) / 4
        + at.day
        - 32075;
    let julian_date = aux2 as f64 - 0.5 + dec_hours / 24.0;
    let elapsed = julian_date - 2451545.0;

    let omega = 2.1429 - 0.0010394594 * elapsed;
    let mean_longitude = 4.8950630 + 0.017202791698 * elapsed;
    let anomaly = 6.2400600 + 0.0172019699 * elapsed;
    let ecliptic_longitude =
        mean_longitude + 0.03341607 * anomaly.sin() + 0.00034894 * (2.0 * anomaly).sin()
            - 0.0001134
            - 0.0000203 * omega.sin();
    let ecliptic_obliquity = 0.4090928 - 6.2140e-9 * elapsed + 0.0000396 * omega.cos();

    let sin_el = ecliptic_longitude.sin();
    let mut right_ascension = (ecliptic_obliquity.cos() * sin_el).atan2(ecliptic_longitude.cos());
    if right_ascension < 0.0 {
        right_ascension += 2.0 * PI;
    }
    let declination = (ecliptic_obliquity.sin() * sin_el).asin();

    let gmst = 6.6974243242 + 0.0657098283 * elapsed + dec_hours;
    let lmst = (gmst * 15.0 + at.longitude).to_radians();
    let lat = at.latitude.to_radians();
    let hour_angle = lmst - right_ascension;
    let mut zenith = (lat.cos() * hour_angle.cos() * declination.cos()
        + declination.sin() * lat.sin())
    .clamp(-1.0, 1.0)
    .acos();
    let dy = -hour_angle.sin();
    let dx = declination.tan() * lat.cos() - lat.sin() * hour_angle.cos();
    let mut azimuth = dy.atan2(dx);
    if azimuth < 0.0 {
        azimuth += 2.0 * PI;
    }
    // Parallax correction (Earth mean radius over the astronomical unit, in km).
    zenith += (6371.01 / 149597890.0) * zenith.sin();
    (zenith, azimuth)
}

/// The unit direction towards the sun in Mitsuba's local sky frame (Y up), as its `toSphere`:
/// (sin φ sin θ, cos θ, −cos φ sin θ).
pub fn sun_direction_local(at: &SunTimePlace) -> DVec3 {
    let (theta, phi) = sun_zenith_azimuth(at);
    DVec3::new(
        phi.sin() * theta.sin(),
        theta.cos(),
        -phi.cos() * theta.sin(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noon_sun_is_high_in_summer_and_low_in_winter() {
        // Greenwich, local noon at the solstices: zenith ≈ latitude ∓ 23.44°.
        let mut at = SunTimePlace {
            year: 2010,
            month: 6,
            day: 21,
            hour: 12.0,
            latitude: 51.48,
            longitude: 0.0,
            timezone: 0.0,
            ..Default::default()
        };
        let (z, a) = sun_zenith_azimuth(&at);
        assert!(
            (z.to_degrees() - (51.48 - 23.44)).abs() < 1.0,
            "{}",
            z.to_degrees()
        );
        assert!(
            (a.to_degrees() - 180.0).abs() < 5.0,
            "due south: {}",
            a.to_degrees()
        );
        at.month = 12;
        let (z, _) = sun_zenith_azimuth(&at);
        assert!(
            (z.to_degrees() - (51.48 + 23.44)).abs() < 1.0,
            "{}",
            z.to_degrees()
        );
        // Morning sun is in the east (azimuth < 180°), evening sun in the west.
        at.month = 6;
        at.hour = 8.0;
        assert!(sun_zenith_azimuth(&at).1.to_degrees() < 120.0);
        at.hour = 17.0;
        assert!(sun_zenith_azimuth(&at).1.to_degrees() > 240.0);
        let d = sun_direction_local(&at);
        assert!((d.length() - 1.0).abs() < 1e-12 && d.y > 0.0);
    }
}
