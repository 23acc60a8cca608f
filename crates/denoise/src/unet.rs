//! OIDN's U-Net (the base and "small" networks share it; only their widths
//! differ, which the weights carry):
//!
//! ```text
//! input ─ enc_conv0 ─ enc_conv1 ─ pool1 ─ enc_conv2 ─ pool2 ─ enc_conv3 ─ pool3
//!   │                               │                   │                 │
//!   │           enc_conv4 ─ pool4 ─ enc_conv5a ─ enc_conv5b ─ up ─ [·, pool3]
//!   │                               │                   │       dec_conv4a, 4b ─ up
//!   │                               │                   └──── [·, pool2] dec_conv3a, 3b ─ up
//!   │                               └──────────────────────── [·, pool1] dec_conv2a, 2b ─ up
//!   └──────────────────────────────────────────────────────── [·, input] dec_conv1a, 1b, dec_conv0
//! ```
//!
//! Every convolution is 3×3 with a ReLU (the last one too: the output is
//! clamped at 0 anyway); pooling is 2×2 max, upsampling 2× nearest;
//! `[·, skip]` concatenates the upsampled maps first and the skip second.
//! The input's size must be a multiple of 16 (four poolings).

use crate::conv::Conv3x3;
use crate::planes::Planes;
use crate::tza::{Archive, TzaError};
use crate::upconv::UpConv3x3;

/// What is wrong with a set of weights.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WeightsError {
    /// The archive cannot be read.
    #[error(transparent)]
    Archive(#[from] TzaError),
    /// A layer's weights or bias is missing or of another shape.
    #[error("layer `{layer}`: {fault}")]
    Layer {
        /// The layer's name (`enc_conv0`).
        layer: &'static str,
        /// What is wrong.
        fault: String,
    },
}

/// The network's layers, as the weights give them.
#[derive(Debug, Clone)]
struct Layers {
    enc_conv0: Conv3x3,
    enc_conv1: Conv3x3,
    enc_conv2: Conv3x3,
    enc_conv3: Conv3x3,
    enc_conv4: Conv3x3,
    enc_conv5a: Conv3x3,
    enc_conv5b: Conv3x3,
    dec_conv4a: Conv3x3,
    dec_conv4b: Conv3x3,
    dec_conv3a: Conv3x3,
    dec_conv3b: Conv3x3,
    dec_conv2a: Conv3x3,
    dec_conv2b: Conv3x3,
    dec_conv1a: Conv3x3,
    dec_conv1b: Conv3x3,
    dec_conv0: Conv3x3,
}

/// The network, its weights loaded.
#[derive(Debug, Clone)]
pub struct UNet {
    layers: Layers,
    /// `dec_conv4a` … `dec_conv1a` as they are run: on their upsampled
    /// input without making it.
    up: [UpConv3x3; 4],
}

/// The layer `name` of `archive`: weights `o × i × 3 × 3` and bias `o`.
fn layer(archive: &Archive, name: &'static str) -> Result<Conv3x3, WeightsError> {
    let fault = |fault: String| WeightsError::Layer { layer: name, fault };
    let weight_name = format!("{name}.weight");
    let bias_name = format!("{name}.bias");
    let w = archive
        .tensor(&weight_name)
        .ok_or_else(|| fault("no weights".into()))?;
    let [o, i, 3, 3] = w.dims[..] else {
        return Err(fault(format!(
            "weights of shape {:?}, not o × i × 3 × 3",
            w.dims
        )));
    };
    let weight = archive.values(&weight_name).expect("the tensor exists");
    let bias = archive
        .values(&bias_name)
        .ok_or_else(|| fault("no bias".into()))?;
    Conv3x3::new(o, i, weight, bias).ok_or_else(|| {
        fault(format!(
            "a bias of {} for {o} outputs",
            archive.tensor(&bias_name).map_or(0, |b| b.len())
        ))
    })
}

impl Layers {
    /// Each layer takes what the one before gives (and the skips).
    fn check_widths(&self) -> Result<(), WeightsError> {
        let chain: [(&'static str, &Conv3x3, usize); 15] = [
            ("enc_conv1", &self.enc_conv1, self.enc_conv0.outputs),
            ("enc_conv2", &self.enc_conv2, self.enc_conv1.outputs),
            ("enc_conv3", &self.enc_conv3, self.enc_conv2.outputs),
            ("enc_conv4", &self.enc_conv4, self.enc_conv3.outputs),
            ("enc_conv5a", &self.enc_conv5a, self.enc_conv4.outputs),
            ("enc_conv5b", &self.enc_conv5b, self.enc_conv5a.outputs),
            (
                "dec_conv4a",
                &self.dec_conv4a,
                self.enc_conv5b.outputs + self.enc_conv3.outputs,
            ),
            ("dec_conv4b", &self.dec_conv4b, self.dec_conv4a.outputs),
            (
                "dec_conv3a",
                &self.dec_conv3a,
                self.dec_conv4b.outputs + self.enc_conv2.outputs,
            ),
            ("dec_conv3b", &self.dec_conv3b, self.dec_conv3a.outputs),
            (
                "dec_conv2a",
                &self.dec_conv2a,
                self.dec_conv3b.outputs + self.enc_conv1.outputs,
            ),
            ("dec_conv2b", &self.dec_conv2b, self.dec_conv2a.outputs),
            (
                "dec_conv1a",
                &self.dec_conv1a,
                self.dec_conv2b.outputs + self.enc_conv0.inputs,
            ),
            ("dec_conv1b", &self.dec_conv1b, self.dec_conv1a.outputs),
            ("dec_conv0", &self.dec_conv0, self.dec_conv1b.outputs),
        ];
        for (layer, conv, inputs) in chain {
            if conv.inputs != inputs {
                return Err(WeightsError::Layer {
                    layer,
                    fault: format!("takes {} channels, but is given {inputs}", conv.inputs),
                });
            }
        }
        Ok(())
    }
}

impl UNet {
    /// The network of the weights in the TZA archive `bytes`.
    pub fn load(bytes: &[u8]) -> Result<UNet, WeightsError> {
        let a = Archive::parse(bytes)?;
        let net = Layers {
            enc_conv0: layer(&a, "enc_conv0")?,
            enc_conv1: layer(&a, "enc_conv1")?,
            enc_conv2: layer(&a, "enc_conv2")?,
            enc_conv3: layer(&a, "enc_conv3")?,
            enc_conv4: layer(&a, "enc_conv4")?,
            enc_conv5a: layer(&a, "enc_conv5a")?,
            enc_conv5b: layer(&a, "enc_conv5b")?,
            dec_conv4a: layer(&a, "dec_conv4a")?,
            dec_conv4b: layer(&a, "dec_conv4b")?,
            dec_conv3a: layer(&a, "dec_conv3a")?,
            dec_conv3b: layer(&a, "dec_conv3b")?,
            dec_conv2a: layer(&a, "dec_conv2a")?,
            dec_conv2b: layer(&a, "dec_conv2b")?,
            dec_conv1a: layer(&a, "dec_conv1a")?,
            dec_conv1b: layer(&a, "dec_conv1b")?,
            dec_conv0: layer(&a, "dec_conv0")?,
        };
        net.check_widths()?;
        let up = |conv: &Conv3x3, below: &Conv3x3| {
            UpConv3x3::new(conv, below.outputs).expect("the widths were checked")
        };
        Ok(UNet {
            up: [
                up(&net.dec_conv4a, &net.enc_conv5b),
                up(&net.dec_conv3a, &net.dec_conv4b),
                up(&net.dec_conv2a, &net.dec_conv3b),
                up(&net.dec_conv1a, &net.dec_conv2b),
            ],
            layers: net,
        })
    }

    /// The input channels it takes.
    pub fn input_channels(&self) -> usize {
        self.layers.enc_conv0.inputs
    }

    /// The output channels it gives.
    pub fn output_channels(&self) -> usize {
        self.layers.dec_conv0.outputs
    }

    /// Runs the network on `input` (its size a multiple of 16).
    pub fn forward(&self, input: &Planes) -> Planes {
        assert_eq!(input.channels, self.input_channels());
        let l = &self.layers;
        assert!(input.height.is_multiple_of(16) && input.width.is_multiple_of(16));
        let x = l.enc_conv0.forward(&[input]);
        let pool1 = l.enc_conv1.forward(&[&x]).max_pool();
        let pool2 = l.enc_conv2.forward(&[&pool1]).max_pool();
        let pool3 = l.enc_conv3.forward(&[&pool2]).max_pool();
        let pool4 = l.enc_conv4.forward(&[&pool3]).max_pool();
        let x = l.enc_conv5a.forward(&[&pool4]);
        drop(pool4);
        let low = l.enc_conv5b.forward(&[&x]);
        let x = self.up[0].forward(&low, &pool3);
        drop(pool3);
        let low = l.dec_conv4b.forward(&[&x]);
        let x = self.up[1].forward(&low, &pool2);
        drop(pool2);
        let low = l.dec_conv3b.forward(&[&x]);
        let x = self.up[2].forward(&low, &pool1);
        drop(pool1);
        let low = l.dec_conv2b.forward(&[&x]);
        let x = self.up[3].forward(&low, input);
        drop(low);
        let x = l.dec_conv1b.forward(&[&x]);
        l.dec_conv0.forward(&[&x])
    }
}
