//! A small log-log line plot as inline SVG (no script, no external files), for the report's
//! error-versus-time chart.

/// One named series of (x, y) points, both positive.
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

const COLOURS: [&str; 8] = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"];

pub fn loglog_svg(series: &[Series], x_label: &str, y_label: &str) -> String {
    // The right margin holds the legend.
    let (w, h, pad, legend) = (800.0, 400.0, 60.0, 160.0);
    let pts = series.iter().flat_map(|s| s.points.iter()).filter(|p| p.0 > 0.0 && p.1 > 0.0);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        x0 = x0.min(x.log10());
        x1 = x1.max(x.log10());
        y0 = y0.min(y.log10());
        y1 = y1.max(y.log10());
    }
    if x0 > x1 {
        return "<p>(no data to plot)</p>".to_owned();
    }
    let (x0, x1) = (x0.floor(), x1.ceil().max(x0.floor() + 1.0));
    let (y0, y1) = (y0.floor(), y1.ceil().max(y0.floor() + 1.0));
    let sx = |x: f64| pad + (x.log10() - x0) / (x1 - x0) * (w - 2.0 * pad - legend);
    let sy = |y: f64| h - pad - (y.log10() - y0) / (y1 - y0) * (h - 2.0 * pad);
    let mut svg = format!(r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"##);
    svg += &format!(
        r##"<rect x="{pad}" y="{pad}" width="{}" height="{}" fill="none" stroke="#888"/>"##,
        w - 2.0 * pad - legend,
        h - 2.0 * pad
    );
    for d in x0 as i32..=x1 as i32 {
        let x = sx(10f64.powi(d));
        svg += &format!(
            r##"<line x1="{x}" y1="{pad}" x2="{x}" y2="{}" stroke="#eee"/><text x="{x}" y="{}" text-anchor="middle">1e{d}</text>"##,
            h - pad,
            h - pad + 16.0
        );
    }
    for d in y0 as i32..=y1 as i32 {
        let y = sy(10f64.powi(d));
        svg += &format!(
            r##"<line x1="{pad}" y1="{y}" x2="{}" y2="{y}" stroke="#eee"/><text x="{}" y="{}" text-anchor="end">1e{d}</text>"##,
            w - pad - legend,
            pad - 6.0,
            y + 4.0
        );
    }
    svg += &format!(r##"<text x="{}" y="{}" text-anchor="middle">{x_label}</text>"##, (w - legend) / 2.0, h - 16.0);
    svg += &format!(r##"<text x="14" y="{}" text-anchor="middle" transform="rotate(-90 14 {})">{y_label}</text>"##, h / 2.0, h / 2.0);
    for (i, s) in series.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let p: Vec<String> =
            s.points.iter().filter(|p| p.0 > 0.0 && p.1 > 0.0).map(|&(x, y)| format!("{:.1},{:.1}", sx(x), sy(y))).collect();
        if p.is_empty() {
            continue;
        }
        svg += &format!(r##"<polyline points="{}" fill="none" stroke="{c}" stroke-width="2"/>"##, p.join(" "));
        for q in &p {
            let (x, y) = q.split_once(',').unwrap_or(("0", "0"));
            svg += &format!(r##"<circle cx="{x}" cy="{y}" r="3" fill="{c}"/>"##);
        }
        let ly = pad + 16.0 * (i as f64 + 1.0);
        svg += &format!(
            r##"<rect x="{}" y="{}" width="10" height="10" fill="{c}"/><text x="{}" y="{}">{}</text>"##,
            w - pad - legend + 12.0,
            ly - 9.0,
            w - pad - legend + 26.0,
            ly,
            html_escape(&s.name)
        );
    }
    svg + "</svg>"
}

pub fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plot_has_one_polyline_per_series_and_escapes_names() {
        let s = vec![
            Series { name: "a<b".into(), points: vec![(1.0, 0.1), (10.0, 0.01)] },
            Series { name: "c".into(), points: vec![(2.0, 0.5)] },
        ];
        let svg = loglog_svg(&s, "ms", "RMSE");
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(svg.contains("a&lt;b") && svg.starts_with("<svg") && svg.ends_with("</svg>"));
        assert!(loglog_svg(&[], "x", "y").contains("no data"));
    }
}
