//! C++ iostream default float formatting (printf `%g` with 6 significant digits).

/// Significant digits of the C++ default stream precision.
const PRECISION: i32 = 6;

/// Formats `x` as C++ `std::cout << x` does by default (`%g`, precision 6): 6 significant
/// digits, trailing zeros and point removed, scientific form when the decimal exponent
/// is below -4 or at least 6.
pub fn format_g(x: f64) -> String {
    format_g_with(x, PRECISION)
}

/// Formats an f32 in `%g` style with the fewest significant digits (6 to 9) that read
/// back as the same f32: how messages name a value, so two values never print alike.
pub fn format_g_exact(x: f32) -> String {
    (PRECISION..=9)
        .map(|digits| format_g_with(x.into(), digits))
        .find(|text| text.parse::<f32>().is_ok_and(|back| back == x))
        .unwrap_or_else(|| format_g_with(x.into(), 9))
}

/// `%g` with `precision` significant digits.
fn format_g_with(x: f64, precision: i32) -> String {
    if x.is_nan() {
        return if x.is_sign_negative() { "-nan" } else { "nan" }.to_string();
    }
    if x.is_infinite() {
        return if x < 0.0 { "-inf" } else { "inf" }.to_string();
    }
    if x == 0.0 {
        return if x.is_sign_negative() { "-0" } else { "0" }.to_string();
    }
    // The exponent after rounding to `precision` significant digits decides the style.
    let scientific = format!("{:.*e}", (precision - 1) as usize, x);
    let (mantissa, exponent) = scientific
        .split_once('e')
        .expect("Rust's {:e} output always has an exponent");
    let exponent: i32 = exponent.parse().expect("exponent is an integer");
    if (-4..precision).contains(&exponent) {
        let decimals = (precision - 1 - exponent) as usize;
        trim_fraction(&format!("{x:.decimals$}")).to_string()
    } else {
        let sign = if exponent < 0 { '-' } else { '+' };
        format!("{}e{sign}{:02}", trim_fraction(mantissa), exponent.abs())
    }
}

/// Formats `x` with the fewest digits that read back as the same f64, as Rust's `{}`
/// does, but in scientific form (`1e-300`, `2.5e20`) where plain digits would run long:
/// magnitudes below 1e-5 or from 1e16. How CSV files and timing lines write a number.
pub fn format_shortest(x: f64) -> String {
    let magnitude = x.abs();
    if magnitude != 0.0 && magnitude.is_finite() && !(1e-5..1e16).contains(&magnitude) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// Formats a positive rate with three decimals (`9.540`), or in scientific form with
/// three (`2.516e296`) from 1e6 on, where the decimals would run to hundreds of digits.
pub fn format_rate(x: f64) -> String {
    if x.abs() < 1e6 {
        format!("{x:.3}")
    } else {
        format!("{x:.3e}")
    }
}

/// Removes trailing zeros of a fraction, then a trailing decimal point.
fn trim_fraction(digits: &str) -> &str {
    if digits.contains('.') {
        digits.trim_end_matches('0').trim_end_matches('.')
    } else {
        digits
    }
}

#[cfg(test)]
mod tests {
    use super::{format_g, format_g_exact, format_rate, format_shortest};

    #[test]
    fn rates_keep_three_decimals_and_a_short_form() {
        assert_eq!(format_rate(9.54), "9.540");
        assert_eq!(format_rate(999_999.0), "999999.000");
        assert_eq!(format_rate(2.5164e296), "2.516e296");
    }

    #[test]
    fn shortest_form_reads_back_and_stays_short() {
        for (x, text) in [
            (0.25, "0.25"),
            (0.0, "0"),
            (1e-5, "0.00001"),
            (1e-300, "1e-300"),
            (-2.5e20, "-2.5e20"),
            (123456.789, "123456.789"),
            (f64::NAN, "NaN"),
        ] {
            assert_eq!(format_shortest(x), text);
        }
        for x in [1e-300, 3.0e-7, 0.1 + 0.2, 1.7976931348623157e308, 5e-324] {
            let text = format_shortest(x);
            assert!(text.len() <= 24, "{text}");
            assert_eq!(text.parse::<f64>().unwrap(), x);
        }
    }

    #[test]
    fn exact_form_tells_neighbouring_f32_apart() {
        let (a, b) = (13.0385f32, f32::from_bits(13.0385f32.to_bits() + 1));
        assert_eq!(format_g(a.into()), format_g(b.into()));
        assert_eq!(format_g_exact(a), "13.0385");
        assert_eq!(format_g_exact(b), "13.038501");
        assert_eq!(format_g_exact(b).parse::<f32>().unwrap(), b);
        assert_eq!(format_g_exact(1e30), "1e+30");
        assert_eq!(format_g_exact(204.0), "204");
        assert_eq!(format_g_exact(f32::NAN), "nan");
    }

    #[test]
    fn integers_print_without_a_point() {
        assert_eq!(format_g(204.0), "204");
        assert_eq!(format_g(292.0), "292");
        assert_eq!(format_g(-3.0), "-3");
        assert_eq!(format_g(100000.0), "100000");
    }

    #[test]
    fn six_significant_digits_with_trailing_zeros_removed() {
        assert_eq!(format_g(1.695 / 204.0), "0.00830882");
        assert_eq!(format_g(0.13 / 15.0), "0.00866667");
        assert_eq!(format_g(0.5), "0.5");
        assert_eq!(format_g(1.25), "1.25");
        assert_eq!(format_g(123456.4), "123456");
        assert_eq!(format_g(0.0001), "0.0001");
        assert_eq!(format_g(2.0 / 3.0), "0.666667");
    }

    #[test]
    fn small_and_large_magnitudes_use_scientific_form() {
        assert_eq!(format_g(1000.0 / 292.0_f64.powi(3)), "4.01653e-05");
        assert_eq!(format_g(0.00001), "1e-05");
        assert_eq!(format_g(1234567.0), "1.23457e+06");
        assert_eq!(format_g(1e100), "1e+100");
        assert_eq!(format_g(-2.5e-7), "-2.5e-07");
    }

    #[test]
    fn rounding_can_move_the_exponent() {
        // 999999.5 rounds to 1.00000e+06 at 6 digits, so it prints in scientific form.
        assert_eq!(format_g(999999.5), "1e+06");
        assert_eq!(format_g(999999.4), "999999");
        assert_eq!(format_g(0.000099999999), "0.0001");
    }

    #[test]
    fn special_values() {
        assert_eq!(format_g(0.0), "0");
        assert_eq!(format_g(-0.0), "-0");
        assert_eq!(format_g(f64::INFINITY), "inf");
        assert_eq!(format_g(f64::NEG_INFINITY), "-inf");
        assert_eq!(format_g(f64::NAN), "nan");
    }
}
