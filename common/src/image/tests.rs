use super::*;
use crate::stats::RenderStats;
use crate::tile::split_centre_first;

/// A value unique to (layer, pixel, channel), exactly representable in f32.
fn value(layer: usize, x: u32, y: u32, c: usize) -> f32 {
    (layer * 100_000 + y as usize * 1000 + x as usize * 4 + c) as f32 * 0.25
}

fn patterned(width: u32, height: u32) -> Image {
    let mut image = Image::new(width, height);
    for (l, layer) in image.layers_mut().into_iter().enumerate() {
        let n = LAYERS[l].channels;
        for y in 0..height {
            for x in 0..width {
                for c in 0..n {
                    layer[(y * width + x) as usize * n + c] = value(l, x, y, c);
                }
            }
        }
    }
    image
}

fn tile_of(rect: TileRect) -> TilePixels {
    let mut tile = TilePixels::black(rect);
    for (l, layer) in [
        &mut tile.total,
        &mut tile.surface,
        &mut tile.single_scatter,
        &mut tile.multiple_scatter,
        &mut tile.stderr,
        &mut tile.alpha,
    ]
    .into_iter()
    .enumerate()
    {
        let n = LAYERS[l].channels;
        for row in 0..rect.height {
            for col in 0..rect.width {
                for c in 0..n {
                    layer[(row * rect.width + col) as usize * n + c] =
                        value(l, rect.x + col, rect.y + row, c);
                }
            }
        }
    }
    tile
}

fn bits(samples: &[f32]) -> Vec<u32> {
    samples.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn a_tile_lands_where_its_rectangle_says() {
    let mut image = Image::new(7, 5);
    let rect = TileRect {
        x: 2,
        y: 1,
        width: 3,
        height: 2,
    };
    image.insert_tile(&tile_of(rect)).expect("tile fits");
    for (l, layer) in image.layers().into_iter().enumerate() {
        let n = LAYERS[l].channels;
        for y in 0..5 {
            for x in 0..7 {
                let inside = (2..5).contains(&x) && (1..3).contains(&y);
                for c in 0..n {
                    let expected = if inside { value(l, x, y, c) } else { 0.0 };
                    assert_eq!(
                        layer[(y * 7 + x) as usize * n + c],
                        expected,
                        "layer {l} ({x},{y}) c{c}"
                    );
                }
            }
        }
    }
}

#[test]
fn tiles_in_any_order_assemble_the_whole_image() {
    let (w, h) = (37, 23);
    let mut image = Image::new(w, h);
    let mut tiles = split_centre_first(w, h, 8);
    tiles.reverse();
    for rect in tiles {
        image.insert_tile(&tile_of(rect)).expect("tile fits");
    }
    assert_eq!(image, patterned(w, h));
}

#[test]
fn bad_tiles_are_rejected_and_leave_the_image_unchanged() {
    let mut image = patterned(16, 8);
    let before = image.clone();
    let rect = |x, y, width, height| TileRect {
        x,
        y,
        width,
        height,
    };
    for r in [
        rect(10, 0, 7, 4),
        rect(0, 5, 4, 4),
        rect(16, 0, 1, 1),
        rect(u32::MAX, 0, 2, 2),
        rect(0, u32::MAX - 1, 1, 4),
    ] {
        let err = image.insert_tile(&TilePixels::black(r)).unwrap_err();
        assert!(
            matches!(err, ImageError::TileOutside { .. }),
            "{r:?}: {err}"
        );
        assert!(err.to_string().contains("outside"), "{err}");
    }
    let err = image
        .insert_tile(&TilePixels::black(rect(3, 3, 0, 2)))
        .unwrap_err();
    assert!(matches!(err, ImageError::EmptyTile { .. }), "{err}");

    // Wrong buffer lengths, one layer at a time.
    for (layer, kind) in LAYERS.into_iter().enumerate() {
        // 4 × 3 pixels.
        let right = 12 * kind.channels as i64;
        for delta in [-3i64, -1, 1, 3] {
            let mut tile = TilePixels::black(rect(4, 2, 4, 3));
            let buffer = match layer {
                0 => &mut tile.total,
                1 => &mut tile.surface,
                2 => &mut tile.single_scatter,
                3 => &mut tile.multiple_scatter,
                4 => &mut tile.stderr,
                _ => &mut tile.alpha,
            };
            buffer.resize((right + delta) as usize, 0.0);
            let err = image.insert_tile(&tile).unwrap_err();
            let ImageError::BufferLength {
                layer: name,
                expected,
                actual,
            } = err
            else {
                panic!("layer {layer} delta {delta}: {err}")
            };
            assert_eq!(
                (name, expected, actual),
                (kind.name, right as usize, (right + delta) as usize)
            );
        }
    }
    assert_eq!(image, before);
}

#[test]
fn exr_round_trip_is_bit_exact_with_attributes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.exr");
    let mut image = patterned(19, 11);
    // Values a lossy or converting writer would change.
    image.total[0] = f32::NAN;
    image.total[1] = f32::INFINITY;
    image.surface[5] = f32::NEG_INFINITY;
    image.surface[6] = -0.0;
    image.single_scatter[7] = f32::from_bits(1); // the smallest subnormal
    image.single_scatter[8] = f32::MAX;
    image.single_scatter[9] = 1.0e-3;
    image.attributes.insert("spindle.spp".into(), "64".into());
    image
        .attributes
        .insert("spindle.scene".into(), "glass-sphere.json".into());
    image
        .attributes
        .insert("spindle.method".into(), "interval (Holzschuch 2015)".into());
    image
        .attributes
        .insert("spindle.empty".into(), String::new());
    image
        .attributes
        .insert("spindle.latin1".into(), "café".into());
    image
        .attributes
        .insert("spindle.json".into(), r#"{"a": [1, 2]}"#.into());
    // Any Unicode, and a NUL inside a value, survive (values are UTF-8 byte strings).
    image
        .attributes
        .insert("spindle.η".into(), "η = 1.5, 日本/scène.json".into());
    image.attributes.insert("spindle.nul".into(), "a\0b".into());

    image.write_exr(&path).expect("written");
    let back = read_exr(&path).expect("read");
    assert_eq!((back.width, back.height), (19, 11));
    for (kind, (a, b)) in LAYERS
        .iter()
        .zip(image.layers().into_iter().zip(back.layers()))
    {
        assert_eq!(bits(a), bits(b), "layer {}", kind.name);
    }
    assert_eq!(back.attributes, image.attributes);
    assert_eq!(back.non_finite_count(), 2);
    assert_eq!(back.total[2], value(0, 0, 0, 2));
}

#[test]
fn the_same_image_always_gives_the_same_bytes() {
    let mut image = patterned(33, 17);
    for i in 0..12 {
        image
            .attributes
            .insert(format!("spindle.attr{i}"), format!("value {i}"));
    }
    let first = image.to_exr_bytes().unwrap();
    for _ in 0..5 {
        assert!(
            image.to_exr_bytes().unwrap() == first,
            "EXR bytes differ between writes"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.exr");
    image.write_exr(&path).unwrap();
    assert!(std::fs::read(&path).unwrap() == first);
    let png = image.to_png_preview_bytes().unwrap();
    assert!(image.to_png_preview_bytes().unwrap() == png);
    // And the file really is a one-part scanline ZIP file with the thirteen channels.
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(&first), true).unwrap();
    assert_eq!(meta.headers.len(), 1);
    let header = &meta.headers[0];
    assert_eq!(header.compression, exr::prelude::Compression::ZIP16);
    assert_eq!(header.blocks, exr::meta::BlockDescription::ScanLines);
    let names: Vec<String> = header
        .channels
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert_eq!(
        names,
        [
            "A",
            "B",
            "G",
            "R",
            "multiple_scatter.B",
            "multiple_scatter.G",
            "multiple_scatter.R",
            "single_scatter.B",
            "single_scatter.G",
            "single_scatter.R",
            "stderr.B",
            "stderr.G",
            "stderr.R",
            "surface.B",
            "surface.G",
            "surface.R"
        ]
    );
    assert!(
        header
            .channels
            .list
            .iter()
            .all(|c| c.sample_type == exr::prelude::SampleType::F32)
    );
}

#[test]
fn bad_attributes_are_rejected_by_name() {
    for (name, value, word) in [
        ("", "x", "empty"),
        ("channels", "x", "standard"),
        ("comments", "x", "standard"),
        (&"x".repeat(256), "x", "255"),
    ] {
        let mut image = Image::new(2, 2);
        image.attributes.insert(name.into(), value.into());
        let err = image.to_exr_bytes().unwrap_err();
        assert!(
            matches!(&err, ImageError::Attribute { name: n, .. } if n == name),
            "{err}"
        );
        assert!(err.to_string().contains(word), "{err}");
    }
}

#[test]
fn png_preview_is_written_and_decodes_to_the_tone_map() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("preview.png");
    let mut image = Image::new(4, 2);
    // Linear inputs and their 8-bit sRGB values computed by hand from the sRGB curve:
    // 0.5 -> 1.055 * 0.5^(1/2.4) - 0.055 = 0.73536 -> 187.52 -> 188;
    // 0.0031308 -> 12.92 * 0.0031308 = 0.040450 -> 10.31 -> 10;
    // 0.2 -> 1.055 * 0.2^(1/2.4) - 0.055 = 0.48453 -> 123.56 -> 124.
    let cases: [(f32, u8); 8] = [
        (0.0, 0),
        (1.0, 255),
        (0.5, 188),
        (0.003_130_8, 10),
        (0.2, 124),
        (7.5, 255),
        (-2.0, 0),
        (f32::NAN, 0),
    ];
    for (i, (linear, _)) in cases.iter().enumerate() {
        image.total[i * 3..i * 3 + 3].copy_from_slice(&[*linear, *linear, *linear]);
    }
    image.total[1] = f32::INFINITY; // pixel 0, green
    image.surface.fill(9.0); // only `total` is previewed
    image.write_png_preview(&path).expect("written");

    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buffer = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buffer).unwrap();
    assert_eq!((info.width, info.height), (4, 2));
    assert_eq!(
        (info.color_type, info.bit_depth),
        (png::ColorType::Rgb, png::BitDepth::Eight)
    );
    let pixels = &buffer[..info.buffer_size()];
    for (i, (linear, srgb)) in cases.iter().enumerate() {
        let expected_green = if i == 0 { 255 } else { *srgb };
        assert_eq!(
            pixels[i * 3..i * 3 + 3],
            [*srgb, expected_green, *srgb],
            "pixel {i}: {linear}"
        );
    }
    // Nothing but the preview is left in the directory.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["preview.png"]);
}

#[test]
fn writing_replaces_the_old_file_and_reports_failures() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.exr");
    std::fs::write(&path, b"an older render").unwrap();
    let image = patterned(3, 2);
    image.write_exr(&path).unwrap();
    assert_eq!(read_exr(&path).unwrap(), image);
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["out.exr"]);

    let missing = dir.path().join("no-such-dir").join("out.exr");
    assert!(matches!(
        image.write_exr(&missing),
        Err(ImageError::Io { .. })
    ));
    assert!(matches!(
        image.write_png_preview(&missing),
        Err(ImageError::Io { .. })
    ));
    assert!(matches!(read_exr(&missing), Err(ImageError::Io { .. })));
    std::fs::write(&path, b"not an exr file").unwrap();
    assert!(matches!(read_exr(&path), Err(ImageError::Exr { .. })));

    let empty = Image::new(0, 4);
    assert!(matches!(
        empty.write_exr(&path),
        Err(ImageError::EmptyImage { .. })
    ));
    assert!(matches!(
        empty.write_png_preview(&path),
        Err(ImageError::EmptyImage { .. })
    ));
    let mut broken = patterned(3, 2);
    broken.surface.pop();
    let err = broken.write_exr(&path).unwrap_err();
    assert!(
        matches!(
            err,
            ImageError::BufferLength {
                layer: "surface",
                expected: 18,
                actual: 17
            }
        ),
        "{err}"
    );
}

#[test]
fn non_finite_pixels_are_counted_once_each() {
    let mut image = Image::new(5, 4);
    assert_eq!(image.non_finite_count(), 0);
    image.total[3] = f32::NAN; // pixel 1
    image.surface[4] = f32::INFINITY; // pixel 1 again
    image.single_scatter[59] = f32::NEG_INFINITY; // pixel 19, the last
    image.surface[30] = f32::MAX; // finite
    assert_eq!(image.non_finite_count(), 2);
    let mut tile = TilePixels::black(TileRect {
        x: 0,
        y: 0,
        width: 1,
        height: 1,
    });
    tile.total[0] = f32::NAN;
    tile.stats = RenderStats::default();
    image
        .insert_tile(&tile)
        .expect("NaN pixels are inserted as they are");
    assert!(image.total[0].is_nan());
    assert_eq!(image.non_finite_count(), 3);
}

/// An EXR written before the `stderr` layer and alpha existed (nine channels) still reads, with
/// `stderr` 0, alpha 1 (opaque) and the other layers bit for bit.
#[test]
fn files_without_the_stderr_layer_or_alpha_read_with_stderr_zero_and_alpha_one() {
    use exr::prelude::{ReadChannels, ReadLayers, WritableImage};
    let image = patterned(7, 5);
    let bytes = image.to_exr_bytes().unwrap();
    let mut file = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .unwrap();
    file.layer_data.channel_data.list.retain(|c| {
        let name = c.name.to_string();
        !name.starts_with("stderr.") && !name.starts_with("multiple_scatter.") && name != "A"
    });
    assert_eq!(file.layer_data.channel_data.list.len(), 9);
    let mut old = Vec::new();
    file.write()
        .to_buffered(std::io::Cursor::new(&mut old))
        .unwrap();
    let back = Image::from_exr_bytes(&old).unwrap();
    assert!(back.stderr.iter().all(|&v| v == 0.0));
    assert!(back.multiple_scatter.iter().all(|&v| v == 0.0));
    assert_eq!(back.alpha, vec![1.0; 7 * 5]);
    assert_eq!(
        (back.total, back.surface, back.single_scatter),
        (image.total, image.surface, image.single_scatter)
    );
}

/// The relative-error PNG: 0 black, 5 % the preview's grey for 0.5, 10 % and more white, a
/// black pixel with noise white; the decoded PNG holds exactly those bytes.
#[test]
fn the_relative_error_png_shows_stderr_over_total() {
    assert_eq!(relative_error_pixel(0.0, 0.0), 0);
    assert_eq!(relative_error_pixel(0.0, 3.0), 0);
    assert_eq!(relative_error_pixel(0.05, 1.0), preview_pixel(0.5));
    assert_eq!(relative_error_pixel(0.5, -10.0), preview_pixel(0.5));
    assert_eq!(relative_error_pixel(0.2, 1.0), 255);
    assert_eq!(relative_error_pixel(1e-6, 0.0), 255);
    let mut image = Image::new(2, 1);
    image.total = vec![1.0, 2.0, 4.0, 0.0, 0.0, 8.0];
    image.stderr = vec![0.05, 0.0, 1.0, 0.0, 0.3, 0.08];
    let bytes = image.to_png_relative_error_bytes().unwrap();
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(
        &buf[..info.buffer_size()],
        &[preview_pixel(0.5), 0, 255, 0, 255, preview_pixel(0.1)]
    );
}

fn rect(x: u32, y: u32, width: u32, height: u32) -> TileRect {
    TileRect {
        x,
        y,
        width,
        height,
    }
}

#[test]
fn a_window_takes_tiles_in_film_coordinates_and_refuses_the_rest() {
    let window = rect(5, 3, 8, 4);
    let mut image = Image::window(20, 10, window).expect("inside the film");
    assert_eq!((image.width, image.height), (8, 4));
    assert_eq!(image.rect(), window);
    // Two tiles that cover the window between them.
    for r in [rect(5, 3, 8, 2), rect(5, 5, 8, 2)] {
        image.insert_tile(&tile_of(r)).expect("tile fits");
    }
    for (l, layer) in image.layers().into_iter().enumerate() {
        let n = LAYERS[l].channels;
        for row in 0..4 {
            for col in 0..8 {
                for c in 0..n {
                    assert_eq!(
                        layer[(row * 8 + col) as usize * n + c],
                        value(l, 5 + col, 3 + row, c),
                        "layer {l} film pixel ({}, {}) c{c}",
                        5 + col,
                        3 + row
                    );
                }
            }
        }
    }
    let before = image.clone();
    // Inside the film but not the window, on every side, and wrapping around.
    for r in [
        rect(4, 3, 2, 2),
        rect(12, 3, 2, 1),
        rect(5, 2, 1, 2),
        rect(5, 7, 1, 1),
        rect(0, 0, 20, 10),
        rect(u32::MAX, 3, 2, 1),
    ] {
        let err = image.insert_tile(&TilePixels::black(r)).unwrap_err();
        assert!(
            matches!(err, ImageError::TileOutside { .. }),
            "{r:?}: {err}"
        );
    }
    assert_eq!(image, before);
}

#[test]
fn a_window_must_lie_inside_its_film() {
    for w in [rect(15, 0, 6, 1), rect(0, 8, 1, 3), rect(u32::MAX, 0, 2, 1)] {
        let err = Image::window(20, 10, w).unwrap_err();
        assert!(
            matches!(err, ImageError::WindowOutside { .. }),
            "{w:?}: {err}"
        );
    }
    // The fields are public: a window moved out of its film afterwards is not written.
    let mut image = Image::window(20, 10, rect(0, 0, 4, 4)).unwrap();
    image.placement.x = 17;
    assert!(matches!(
        image.to_exr_bytes(),
        Err(ImageError::WindowOutside { .. })
    ));
}

/// A window's position and size.
type Window = ((i32, i32), (usize, usize));

/// The display window and data window of an EXR as the `exr` crate reads its header:
/// `(display position, display size, data position, data size)`.
fn exr_windows(bytes: &[u8]) -> (Window, Window) {
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).unwrap();
    assert_eq!(meta.headers.len(), 1);
    let header = &meta.headers[0];
    let display = header.shared_attributes.display_window;
    let data = header.data_window();
    (
        (
            (display.position.x(), display.position.y()),
            (display.size.width(), display.size.height()),
        ),
        (
            (data.position.x(), data.position.y()),
            (data.size.width(), data.size.height()),
        ),
    )
}

#[test]
fn a_crop_is_the_data_window_inside_the_display_window_and_round_trips() {
    let mut image = Image::window(20, 10, rect(5, 3, 8, 4)).unwrap();
    for r in split_centre_first(8, 4, 3) {
        image
            .insert_tile(&tile_of(rect(5 + r.x, 3 + r.y, r.width, r.height)))
            .unwrap();
    }
    image
        .attributes
        .insert("spindle.region".into(), "5,3,8,4".into());
    let bytes = image.to_exr_bytes().unwrap();
    assert_eq!(exr_windows(&bytes), (((0, 0), (20, 10)), ((5, 3), (8, 4))));
    let back = Image::from_exr_bytes(&bytes).unwrap();
    assert_eq!(back, image);
    for (a, b) in back.layers().iter().zip(image.layers()) {
        assert_eq!(bits(a), bits(b));
    }

    // A full frame: both windows are the frame, as before crops existed.
    let full = patterned(6, 4);
    let bytes = full.to_exr_bytes().unwrap();
    assert_eq!(exr_windows(&bytes), (((0, 0), (6, 4)), ((0, 0), (6, 4))));
    assert_eq!(
        Image::from_exr_bytes(&bytes).unwrap().placement,
        full.placement
    );
}

/// `Precision::Half` writes every channel as a half float: each value reads back as the
/// nearest half (1/3 → 0.33325195, 65504 the largest finite, 1e5 infinite; exact halves
/// unchanged), and the file says it is half.
#[test]
fn half_precision_writes_half_floats_that_read_back_rounded() {
    let mut image = patterned(5, 3);
    image.total[0] = 1.0 / 3.0;
    image.total[1] = 65504.0;
    image.total[2] = 1.0e5;
    image.alpha[0] = 0.5;
    image.precision = Precision::Half;
    let bytes = image.to_exr_bytes().unwrap();
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(&bytes), true).unwrap();
    assert!(
        meta.headers[0]
            .channels
            .list
            .iter()
            .all(|c| c.sample_type == exr::prelude::SampleType::F16)
    );
    let float = Image {
        precision: Precision::Float,
        ..image.clone()
    };
    assert!(bytes.len() < float.to_exr_bytes().unwrap().len());
    let back = Image::from_exr_bytes(&bytes).unwrap();
    assert_eq!(back.precision, Precision::Half);
    assert_eq!(back.total[0], 0.333_251_95);
    assert_eq!(back.total[1], 65504.0);
    assert_eq!(back.total[2], f32::INFINITY);
    assert_eq!(back.alpha[0], 0.5);
    // Every other value is the half nearest to it (the `half` crate's rounding).
    for (a, b) in image.surface.iter().zip(&back.surface) {
        assert_eq!(*b, exr::prelude::f16::from_f32(*a).to_f32());
    }
    assert!(image.surface.iter().zip(&back.surface).any(|(a, b)| a != b));
    assert_eq!(
        Image::from_exr_bytes(&float.to_exr_bytes().unwrap())
            .unwrap()
            .precision,
        Precision::Float
    );
}

/// The optional passes travel like the layers: tiles with them land in place, the EXR file holds
/// them under their channel names (`Z`, `normal.X`, …, `id.id` always 32-bit) and reads back to
/// the same bits; a tile without them is refused by an image that holds them, naming the field.
#[test]
fn optional_passes_are_placed_written_and_read_back() {
    use crate::aov::{Aov, AovSet};
    let passes = AovSet::of(&[Aov::Id, Aov::Depth, Aov::Normal]);
    let k = passes.values_per_pixel();
    let (width, height) = (6, 5);
    let mut image = Image::new(width, height).with_passes(passes);
    for rect in split_centre_first(width, height, 4) {
        let mut tile = tile_of(rect);
        tile.aov = (0..rect.pixel_count() * k)
            .map(|i| {
                let (p, c) = (i / k, i % k);
                let (x, y) = (
                    rect.x + p as u32 % rect.width,
                    rect.y + p as u32 / rect.width,
                );
                value(9, x, y, c)
            })
            .collect();
        image.insert_tile(&tile).unwrap();
    }
    for y in 0..height {
        for x in 0..width {
            for c in 0..k {
                assert_eq!(
                    image.aov[(y * width + x) as usize * k + c],
                    value(9, x, y, c)
                );
            }
        }
    }
    let back = Image::from_exr_bytes(&image.to_exr_bytes().unwrap()).unwrap();
    assert_eq!(back.passes, passes);
    assert_eq!(bits(&back.aov), bits(&image.aov));

    image.precision = Precision::Half;
    let half = Image::from_exr_bytes(&image.to_exr_bytes().unwrap()).unwrap();
    // The id (the last value of each pixel) keeps its 32 bits; the depth is rounded to half.
    for p in 0..(width * height) as usize {
        assert_eq!(half.aov[p * k + k - 1], image.aov[p * k + k - 1]);
    }
    assert!((0..(width * height) as usize).any(|p| half.aov[p * k] != image.aov[p * k]));

    let bare = tile_of(TileRect {
        x: 0,
        y: 0,
        width: 2,
        height: 2,
    });
    let e = image.insert_tile(&bare).unwrap_err().to_string();
    assert_eq!(
        e,
        "the optional passes (`film.passes`: depth, normal, id) have 0 values, expected 20"
    );
    // And an image without passes refuses a tile that has them.
    let mut plain = Image::new(width, height);
    let mut extra = bare.clone();
    extra.aov = vec![0.0; 4];
    assert!(plain.insert_tile(&extra).is_err());
}
