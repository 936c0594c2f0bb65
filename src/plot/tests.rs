use super::*;

fn sample(points: Vec<(f64, f64)>) -> Plot<'static> {
    Plot {
        title: "a < b & c",
        x: Axis::new("input speed", "rpm"),
        y: Axis::new("DTE RMS", "m"),
        series: vec![Series {
            label: "up & down",
            color: "#c0392b",
            points,
            dashed: false,
            markers: true,
            line: true,
        }],
        bands: vec![(1200.0, 1500.0)],
        band_label: "zone",
        markers: vec![Marker {
            x: 2000.0,
            label: "jump up".into(),
        }],
    }
}

#[test]
fn png_is_a_png_of_the_plot_size() {
    let png = sample(vec![(1000.0, 1e-6), (f64::NAN, 1.0), (3000.0, 5e-5)])
        .render(Format::Png)
        .unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let decoder = png::Decoder::new(std::io::Cursor::new(&png));
    let info = decoder.read_info().unwrap().info().clone();
    assert_eq!((info.width, info.height), SIZE);
}

#[test]
fn svg_escapes_text_and_scales_the_unit() {
    let svg = String::from_utf8(
        sample(vec![(1000.0, 1e-6), (3000.0, 5e-5)])
            .render(Format::Svg)
            .unwrap(),
    )
    .unwrap();
    assert!(svg.contains("a &lt; b &amp; c"), "title escaped");
    assert!(svg.contains("DTE RMS (µm)"), "engineering unit on the axis");
    assert!(svg.contains("jump up"));
}

#[test]
fn format_follows_the_extension_and_bad_ones_are_named() {
    assert_eq!(Format::of(Path::new("a/b.PNG")).unwrap(), Format::Png);
    assert_eq!(Format::of(Path::new("b.svg")).unwrap(), Format::Svg);
    let e = Format::of(Path::new("plot.pdf")).unwrap_err();
    assert!(e.contains("plot.pdf") && e.contains(".png"), "{e}");
    assert!(color("red").unwrap_err().contains("\"red\""));
}
