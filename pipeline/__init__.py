"""pcnet.pipeline"""
